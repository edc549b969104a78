"""The summary a pull request and a job summary show: a one-line verdict first, the failures
first, text marks only (no emoji)."""

from __future__ import annotations

from helpers import EMOJI, glance_results

from kartci.report.markdown import summary_md
from kartci.report.tables import verdict_line


def test_the_summary_opens_with_the_verdict_and_the_failures_in_text() -> None:
    md = summary_md(glance_results())
    assert not EMOJI.search(md)
    lines = md.splitlines()
    assert lines[:7] == [
        "## kartci: run errors", "",
        "**FAIL: 2 of 13 scenarios fail: scenario_09 (error), scenario_06 (regressed) "
        "(1 error, 1 regressed, 11 pass)**", "",
        "| scenario | status | sim time | real-time factor |", "|---|---|---|---|",
        "| `scenario_09` | **ERROR** | — | — |"]
    assert lines[7] == "| `scenario_06` | **REGRESSED** | — | — |"
    assert "| `lap_time_s` | 12.5 s | 12 s | +0.5 | ±0.1 (lower) | — | **REGRESSED** |" in lines


def test_a_passing_run_says_so_in_one_line() -> None:
    passing = [r for r in glance_results() if not r.status.bad]
    assert verdict_line(passing) == "PASS: 11 scenarios (11 pass)"
    assert verdict_line([]) == "PASS: 0 scenarios (none)"
