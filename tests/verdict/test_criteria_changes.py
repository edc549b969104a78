"""Issue 40, item 10: a criterion added, removed or changed since the baseline is shown in the
terminal table, the reports and summary.md (the pull-request comment); in CI a removed one
fails until `kartci baseline update` accepts the removal, which the baseline records."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from helpers import kartci

from kartci.core import RunFolder
from kartci.project import current as active_project
from kartci.report import summary_json, summary_md
from kartci.runner.gate import require_baselines
from kartci.scenario import load_scenario
from kartci.verdict import read_baseline
from kartci.verdict.judging import judge_folder
from kartci.verdict.result import ScenarioResult

CRITERIA = {"line_lost": {"equal": 0.0}, "completion": {"min": 0.99},  # line_straight's
            "cross_track_max_m": {"max": 0.002}, "settle_time_s": {"max": 5.0}}
REMOVED = ("criterion cross_track_max_m (<= 0.002) removed since the baseline: the gate no "
           "longer checks it; `kartci baseline update` accepts the removal")


def _judged(tmp_path: Path, criteria: dict[str, dict[str, float]] | None,
            overrides: list[str]) -> ScenarioResult:
    """line_straight judged against a baseline accepted with `criteria` (None: a baseline of
    a kartci that recorded none), after the scenario's criteria were changed by `overrides`."""
    folder = tmp_path / "line_straight"
    folder.mkdir()
    values = {"line_lost": 0.0, "completion": 1.0, "cross_track_max_m": 0.001,
              "settle_time_s": 1.0, "cross_track_rms_m": 0.001}
    (folder / "metrics.json").write_text(json.dumps(
        {"metrics": {k: {"value": v, "unit": ""} for k, v in values.items()}}))
    (folder / "run.json").write_text("{}")
    doc: dict[str, object] = {"scenario": "line_straight", "metrics": {
        k: {"value": v, "unit": "", "tolerance": 0.0, "direction": "equal"}
        for k, v in values.items()}}
    if criteria is not None:
        doc["criteria"] = criteria
    (tmp_path / "line_straight.json").write_text(json.dumps(doc))
    baseline = read_baseline(tmp_path / "line_straight.json")
    spec = load_scenario("line_straight", overrides, project=active_project())
    return judge_folder(RunFolder(folder), spec, baseline, active_project())


NOW = ["criteria={}", "criteria.line_lost.equal=0", "criteria.completion.min=0.95",
       "criteria.settle_time_s.max=5", "criteria.cross_track_rms_m.max=0.01"]
# cross_track_max_m removed, completion changed, cross_track_rms_m added


def test_removed_changed_and_added_criteria_are_warned_and_a_removed_one_fails_in_ci(
        tmp_path: Path) -> None:
    result = _judged(tmp_path, CRITERIA, NOW)
    assert [(c.name, c.kind.value) for c in result.criteria_changes] == [
        ("completion", "changed"), ("cross_track_max_m", "removed"),
        ("cross_track_rms_m", "added")]
    assert "criterion completion changed since the baseline: >= 0.99 -> >= 0.95" \
        in result.warnings
    assert "criterion cross_track_rms_m added since the baseline: <= 0.01" in result.warnings
    assert REMOVED in result.warnings and result.strict_warnings == (REMOVED,)
    strict = require_baselines(result, tmp_path, tmp_path)
    assert strict.problems == (REMOVED,) and strict.status.value == "failed"
    md = summary_md([strict])
    assert f"- **FAILED:** {REMOVED}" in md
    assert "- warning: criterion completion changed since the baseline" in md
    assert summary_json([result])["scenarios"]["line_straight"]["criteria_changes"][1] == {
        "name": "cross_track_max_m", "change": "removed", "before": "<= 0.002", "after": ""}


def test_the_terminal_table_shows_each_change(tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    from kartci.cli.common import print_verdicts
    from kartci.report.tables import RUN

    print_verdicts([_judged(tmp_path, CRITERIA, NOW)], RUN)
    rows = {line.split("│")[1].strip(): line for line in capsys.readouterr().out.splitlines()
            if line.count("│") > 2 and "criterion" in line}
    assert "was <= 0.002" in rows["criterion cross_track_max_m"]
    assert "REMOVED" in rows["criterion cross_track_max_m"]
    assert ">= 0.95 (was >= 0.99)" in rows["criterion completion"]
    assert "<= 0.01 (new)" in rows["criterion cross_track_rms_m"]
    assert rows["criterion settle_time_s"].split("│")[3].strip() == "<= 5"


def test_a_baseline_that_recorded_no_criteria_compares_none(tmp_path: Path) -> None:
    """The baselines committed before this change hold no `criteria`: still valid, no metric
    moved, and nothing said until their next update records the criteria."""
    result = _judged(tmp_path, None, NOW)
    assert result.criteria_changes == () and result.strict_warnings == ()


def test_an_unchanged_set_of_criteria_says_nothing(tmp_path: Path) -> None:
    result = _judged(tmp_path, CRITERIA, [])
    assert result.criteria_changes == ()


def test_a_malformed_criteria_entry_is_a_malformed_baseline(tmp_path: Path) -> None:
    from kartci.errors import BaselineError

    path = tmp_path / "b.json"
    path.write_text(json.dumps({"metrics": {}, "criteria": {"x": {"below": 1}}}))
    with pytest.raises(BaselineError, match=r"criteria\.x: expected bounds max, min or equal"):
        read_baseline(path)


SCENARIO = """\
description: quick line tracker
world: line_lab/straight
duration_s: 0.3
agents:
  lt0:
    model: line_tracker
    controller: {type: line_pid}
metrics:
  line_tracking: {transient_s: 0.1}
criteria:
  completion: {min: 0.0}
  line_lost: {equal: 0}
"""


@pytest.mark.long(reason="several kartci runs end to end")
def test_ci_fails_on_a_removed_criterion_until_baseline_update_accepts_it(
        tmp_path: Path) -> None:
    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('scenarios = ["scenarios"]\n')
    scenario = proj / "scenarios" / "q.yaml"
    scenario.write_text(SCENARIO)
    ci = {"CI": "true"}
    for cmd in (("run", "q", "--out", "out"), ("baseline", "update", "out", "--replicas", "0")):
        p = kartci(*cmd, cwd=proj)
        assert p.returncode == 0, p.stdout + p.stderr
    baseline = json.loads((proj / "baselines" / "q.json").read_text())
    assert baseline["criteria"] == {"completion": {"min": 0.0}, "line_lost": {"equal": 0.0}}
    scenario.write_text(SCENARIO.replace("  line_lost: {equal: 0}\n", ""))
    p = kartci("run", "q", "--out", "out", cwd=proj, env=ci)
    assert p.returncode == 1, p.stdout + p.stderr
    removed = ("criterion line_lost (== 0) removed since the baseline: the gate no longer "
               "checks it; `kartci baseline update` accepts the removal")
    assert f"q: FAILED: {removed}" in p.stdout
    assert f"- **FAILED:** {removed}" in (proj / "out" / "summary.md").read_text()
    assert removed in (proj / "out" / "report.html").read_text()
    p = kartci("baseline", "update", "out", "--replicas", "0", cwd=proj)
    assert p.returncode == 0, p.stderr
    assert "  accepted: criterion line_lost (== 0) removed since the baseline" in p.stdout
    p = kartci("run", "q", "--out", "out", cwd=proj, env=ci)
    assert p.returncode == 0, p.stdout + p.stderr
    shutil.rmtree(proj / "out")
