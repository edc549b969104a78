"""The pull-request summary: short, worst news first (errors, then the largest regressions)."""

from __future__ import annotations

from kartci.report.tables import (
    MARK,
    RUN,
    Wording,
    conditioning,
    delta,
    num,
    regression_size,
    tolerance,
)
from kartci.verdict import SEVERITY, MetricVerdict, Status
from kartci.verdict.result import ScenarioResult, exit_code

VERDICT_WORD = {0: "all scenarios pass", 1: "regressions or failed criteria", 2: "run errors"}


def _verdict_key(v: MetricVerdict) -> tuple[bool, float, str]:
    return (not v.status.bad, -regression_size(v), v.name)


def _scenario_key(r: ScenarioResult) -> tuple[int, float, str]:
    worst = max((regression_size(v) for v in r.verdicts if v.status.bad), default=0.0)
    return (SEVERITY.index(r.status), -worst, r.name)


def summary_md(results: list[ScenarioResult], words: Wording = RUN) -> str:
    """summary.md for a pull request or job summary: the scenarios, worst first, then what
    regressed, failed or warned in each."""
    code = exit_code(results)
    ordered = sorted(results, key=_scenario_key)
    lines = [f"## {words.title}: {VERDICT_WORD[code]}", "",
             "| scenario | status | sim time | real-time factor |", "|---|---|---|---|"]
    for r in ordered:
        rtf = r.run.get("real_time_factor")
        lines.append(f"| `{r.name}` | {MARK[r.status]} {r.status.value} | "
                     f"{num(r.run.get('sim_time_s'), 's')} | {num(rtf)} |")
    for r in ordered:
        if r.error:
            lines += ["", f"### `{r.name}`: error", "", f"> {r.error}"]
            continue
        bad = [v for v in r.verdicts if v.status is not Status.PASS]
        failed = [c for c in r.criteria if not c.ok]
        if not bad and not failed and not r.problems and not r.warnings:
            continue
        lines += ["", f"### `{r.name}`"]
        if failed or r.problems or r.warnings:
            lines.append("")
        lines += [f"- ❌ {p}" for p in r.problems]
        lines += [f"- ⚠️ warning: {w}" for w in r.warnings]
        for c in failed:
            lines.append(f"- ❌ criterion `{c.name}` {c.bound}: got {num(c.value)}")
        if bad:
            lines += ["", f"| metric | value | {words.base} | delta | tolerance | conditioning "
                      "| verdict |", "|---|---|---|---|---|---|---|"]
            for v in sorted(bad, key=_verdict_key):
                lines.append(f"| `{v.name}` | {num(v.value, v.unit)} | {num(v.baseline, v.unit)}"
                             f" | {delta(v)} | {tolerance(v)} | {conditioning(v)} | "
                             f"{MARK[v.status]} {v.status.value} |")
    lines.append("")
    return "\n".join(lines)
