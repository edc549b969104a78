"""The pull-request summary: short, worst news first (errors, then the largest regressions)."""

from __future__ import annotations

from kartci.report.tables import (
    RUN,
    Wording,
    conditioning,
    delta,
    marked,
    num,
    regression_size,
    tolerance,
    verdict_line,
    worst_first,
)
from kartci.verdict import MetricVerdict, Status
from kartci.verdict.result import ScenarioResult, exit_code

VERDICT_WORD = {0: "all scenarios pass", 1: "regressions or failed criteria", 2: "run errors"}


def _verdict_key(v: MetricVerdict) -> tuple[bool, float, str]:
    return (not v.status.bad, -regression_size(v), v.name)


def _mark(status: Status) -> str:
    """A status as Markdown text (no emoji): a failing one in bold capitals."""
    return f"**{marked(status)}**" if status.bad else marked(status)


def summary_md(results: list[ScenarioResult], words: Wording = RUN) -> str:
    """summary.md for a pull request or job summary: the scenarios, worst first, then what
    regressed, failed or warned in each, under a one-line verdict. Text marks only: it is
    read in terminals and CI logs as well as on GitHub."""
    code = exit_code(results)
    ordered = worst_first(results)
    lines = [f"## {words.title}: {VERDICT_WORD[code]}", "", f"**{verdict_line(results)}**", "",
             "| scenario | status | sim time | real-time factor |", "|---|---|---|---|"]
    for r in ordered:
        rtf = r.run.get("real_time_factor")
        lines.append(f"| `{r.name}` | {_mark(r.status)} | "
                     f"{num(r.run.get('sim_time_s'), 's')} | {num(rtf)} |")
    for r in ordered:
        if r.error:
            lines += ["", f"### `{r.name}`: ERROR", "", f"> {r.error}"]
            continue
        bad = [v for v in r.verdicts if v.status is not Status.PASS]
        failed = [c for c in r.criteria if not c.ok]
        if not bad and not failed and not r.problems and not r.warnings:
            continue
        lines += ["", f"### `{r.name}`"]
        if failed or r.problems or r.warnings:
            lines.append("")
        lines += [f"- **FAILED:** {p}" for p in r.problems]
        lines += [f"- warning: {w}" for w in r.warnings]
        for c in failed:
            lines.append(f"- **FAILED:** criterion `{c.name}` {c.bound}: got {num(c.value)}")
        if bad:
            lines += ["", f"| metric | value | {words.base} | delta | tolerance | conditioning "
                      "| verdict |", "|---|---|---|---|---|---|---|"]
            for v in sorted(bad, key=_verdict_key):
                lines.append(f"| `{v.name}` | {num(v.value, v.unit)} | {num(v.baseline, v.unit)}"
                             f" | {delta(v)} | {tolerance(v)} | {conditioning(v)} | "
                             f"{_mark(v.status)} |")
    lines.append("")
    return "\n".join(lines)
