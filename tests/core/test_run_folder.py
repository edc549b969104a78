"""`RunFolder` names exactly what a run writes: a real run's folder listing is its names."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from kartci.api import load_scenario
from kartci.core import UNFINISHED, Outbox, RunFolder
from kartci.errors import SpecError
from kartci.logs import SCENARIO_TOPIC, messages
from kartci.robots.line_tracker.line_pid import LinePid
from kartci.runner.run import run_one

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))

from layers import edges

OVERRIDES = ["duration_s=0.5", "criteria={}", "metrics.line_tracking.transient_s=0.1"]


def test_a_finished_run_holds_exactly_the_run_folders_outputs(tmp_path: Path) -> None:
    run_one(load_scenario("line_straight", OVERRIDES), tmp_path)
    folder = RunFolder(tmp_path / "line_straight")
    assert sorted(p.name for p in folder.path.iterdir()) == sorted(RunFolder.OUTPUTS)
    assert [folder.log, folder.metrics, folder.run_record] == [
        folder.path / name for name in RunFolder.OUTPUTS]
    assert (folder.failure(), folder.missing(), folder.stages()) == (None, [], [])
    assert folder.read_metrics() == json.loads(folder.metrics.read_text())["metrics"]
    assert folder.read_run_record()["log"] == str(folder.log)
    assert next(messages(folder.log))[0] == SCENARIO_TOPIC


def test_a_crashed_run_leaves_its_error_and_traceback_under_the_run_folders_names(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    def step(self: LinePid, t_ns: int) -> Outbox:
        raise ZeroDivisionError("controller bug")

    monkeypatch.setattr(LinePid, "step", step)
    with pytest.raises(ZeroDivisionError):
        run_one(load_scenario("line_straight", OVERRIDES), tmp_path)
    folder = RunFolder(tmp_path / "line_straight")
    assert sorted(p.name for p in folder.path.iterdir()) == sorted(
        [folder.error.name, folder.traceback.name])
    assert "ZeroDivisionError: controller bug" in (folder.failure() or "")
    assert folder.missing() == [RunFolder.LOG_NAME, RunFolder.METRICS_NAME]
    assert folder.read_run_record() == {}


def test_a_folder_marked_unfinished_says_so(tmp_path: Path) -> None:
    RunFolder(tmp_path).mark_failed("x", UNFINISHED)
    assert RunFolder(tmp_path).unfinished()
    stage = RunFolder(tmp_path).new_stage()
    assert stage.path.parent == tmp_path and RunFolder(tmp_path).stages() == [stage.path]


def test_core_imports_nothing_above_it() -> None:
    """Every package may ask a RunFolder for a name: core stays the bottom of the graph."""
    below = {"kartci.atomic", "kartci.boundedio", "kartci.errors", "kartci.project"}
    assert {e.target for e in edges() if e.source == "kartci.core"} <= below


def test_the_run_state_is_read_and_written_through_the_run_folder(tmp_path: Path) -> None:
    """A failure mark written by `mark_failed` is what `failed_reason` reads back (one line)
    and what makes `check_complete` refuse the folder; a KartciError leaves no traceback."""
    folder = RunFolder(tmp_path / "s")
    with pytest.raises(SpecError, match="no such scenario folder"):
        folder.check_complete()
    folder.path.mkdir()
    assert folder.failed_reason() is None
    folder.mark_failed("s", "bad\ninput", SpecError("bad"))
    assert folder.failed_reason() == "the last run failed: bad input"
    assert not folder.traceback.exists()
    with pytest.raises(SpecError, match=r"failed \(bad input\); its metrics are stale"):
        folder.check_complete()
    folder.error.unlink()
    with pytest.raises(SpecError, match=r"incomplete \(no run.mcap or metrics.json\)"):
        folder.check_complete()
    folder.mark_failed("s", "crash", ZeroDivisionError("x"))
    assert "ZeroDivisionError: x" in folder.traceback.read_text()
