"""The pull-request summary: short, worst news first."""

from __future__ import annotations

from kartci.report.tables import MARK, delta, num, tolerance
from kartci.results import ScenarioResult, exit_code
from kartci.verdict import Status

VERDICT_WORD = {0: "all scenarios pass", 1: "regressions or failed criteria", 2: "run errors"}


def summary_md(results: list[ScenarioResult]) -> str:
    code = exit_code(results)
    lines = [f"## kartci: {VERDICT_WORD[code]}", "",
             "| scenario | status | sim time | real-time factor |", "|---|---|---|---|"]
    for r in results:
        rtf = r.run.get("real_time_factor")
        lines.append(f"| `{r.name}` | {MARK[r.status]} {r.status.value} | "
                     f"{num(r.run.get('sim_time_s'), 's')} | {num(rtf)} |")
    for r in results:
        if r.error:
            lines += ["", f"### `{r.name}`: error", "", f"> {r.error}"]
            continue
        bad = [v for v in r.verdicts if v.status is not Status.PASS]
        failed = [c for c in r.criteria if not c.ok]
        if not bad and not failed:
            continue
        lines += ["", f"### `{r.name}`", ""]
        for c in failed:
            lines.append(f"- ❌ criterion `{c.name}` {c.bound}: got {num(c.value)}")
        if bad:
            lines += ["", "| metric | value | baseline | delta | tolerance | verdict |",
                      "|---|---|---|---|---|---|"]
            for v in sorted(bad, key=lambda v: (not v.status.bad, v.name)):
                lines.append(f"| `{v.name}` | {num(v.value, v.unit)} | {num(v.baseline, v.unit)}"
                             f" | {delta(v)} | {tolerance(v)} | {MARK[v.status]} "
                             f"{v.status.value} |")
    lines.append("")
    return "\n".join(lines)
