"""Issue 29: the Python API judges a run against a baseline only when the baseline was accepted
from the scenario that ran; otherwise it says there is no comparable baseline and two runs are
compared instead (`kartci.compare`)."""

from __future__ import annotations

from pathlib import Path

import kartci
from kartci.verdict import Status

QUICK = ("duration_s=3", "metrics.line_tracking.transient_s=1", "criteria={}")


def test_a_run_of_another_scenario_is_not_judged_against_the_baseline(tmp_path: Path) -> None:
    base_dir = tmp_path / "baselines"
    base = kartci.run("line_straight", overrides=QUICK, out=tmp_path / "base",
                      baselines=base_dir)
    kartci.accept_baselines(base, baselines=base_dir, replicas=0)
    head = kartci.run("line_straight", overrides=[*QUICK, "agents.lt0.controller.kp=60",
                                                  "duration_s=4"],
                      out=tmp_path / "head", baselines=base_dir)
    assert {v.status for v in head.verdicts} == {Status.NEW}
    assert all(v.baseline is None for v in head.verdicts) and head.baseline is None
    assert head.passed  # nothing to regress against: not a failure, and said so
    assert head.warnings == (
        "no comparable baseline: line_straight.json was accepted from another scenario "
        "(fields: agents.lt0.controller.kp, duration_s), so its metrics are not compared "
        "(verdicts new); compare two runs instead (kartci.compare(base, head)), or accept this "
        "one (kartci.accept_baselines(result))",)
    assert "warning: no comparable baseline: " in head.table()
    assert "scenario line_straight: new (no baseline)" in head.table()

    # what it offers instead: head against base, metric by metric, with baseline tolerances
    diff = kartci.compare(base, head)
    speed = next(v for v in diff.verdicts if v.name == "mean_speed_mps")
    assert speed.baseline == base.value("mean_speed_mps")
    assert speed.value == head.value("mean_speed_mps")
    assert diff.baseline == base.folder / "metrics.json" and diff.criteria == []
    assert {v.status for v in diff.verdicts} <= {Status.PASS, Status.IMPROVED,
                                                 Status.REGRESSED}
    assert kartci.compare(base, base).passed
