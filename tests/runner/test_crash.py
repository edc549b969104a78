"""A run that crashes, goes NaN or overruns its time limit is an error for that scenario only."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml
from helpers import PAIR, QUICK, kartci

from kartci.core import Outbox
from kartci.project import BUILTIN_SCENARIOS
from kartci.project import current as active_project
from kartci.report import write_all
from kartci.robots.line_tracker.line_pid import LinePid
from kartci.runner import expand, run_jobs
from kartci.verdict import Status
from kartci.verdict.result import exit_code

SCENARIOS = BUILTIN_SCENARIOS


def test_a_controller_exception_fails_its_scenario_only(tmp_path: Path, baselines: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    real = LinePid.step

    def step(self: LinePid, t_ns: int) -> Outbox:
        if self.spec.kp == 100.0 and t_ns > 500_000_000:  # line_straight's gain, after 0.5 s
            raise ZeroDivisionError("controller bug")
        return real(self, t_ns)

    monkeypatch.setattr(LinePid, "step", step)
    jobs = expand(PAIR, ["duration_s=2", "criteria={}", "metrics.line_tracking.transient_s=0.5"],
                  active_project())
    results = {r.name: r for r in run_jobs(jobs, tmp_path, baselines, active_project())}
    assert results["line_straight"].status is Status.ERROR
    assert "ZeroDivisionError: controller bug" in (results["line_straight"].error or "")
    assert results["line_circle"].status is Status.NEW  # finished and scored
    assert (tmp_path / "line_circle" / "metrics.json").exists()
    assert (tmp_path / "line_straight" / "error.json").exists()
    paths = write_all(list(results.values()), tmp_path)
    assert "controller bug" in paths["html"].read_text()
    assert exit_code(list(results.values())) == 2


NAN_PLUGIN = """
from typing import Any, Literal

import numpy as np

from kartci.logs import header, msg
from kartci.core import Controller, register
from kartci.scenario.models import ControllerParams


class Params(ControllerParams):
    type: Literal["nan_wheels"] = "nan_wheels"
    period_s: float = 0.01


class NanWheels:
    inputs: tuple[str, ...] = ()

    def __init__(self, params: Params, ctx: Any) -> None:
        self.period_s = params.period_s

    def on_message(self, topic: str, message: Any) -> None:
        pass

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        return [("wheel_cmd", msg("sensor_msgs/msg/JointState", header=header(t_ns, "lt0"),
                                  name=[], position=np.zeros(0), effort=np.zeros(0),
                                  velocity=np.array([np.nan, np.nan])))]


register(Controller("nan_wheels", Params, NanWheels, ("line_tracker",)))
"""


@pytest.mark.long(reason="kartci runs end to end")
def test_nan_state_in_a_pool_and_the_report_is_still_written(tmp_path: Path,
                                                             baselines: Path) -> None:
    """A controller that commands NaN (a team's plugin, imported in the workers too) drives
    the state non-finite: an error for that scenario only; the other finishes, reports are
    written, exit 2. (A NaN in a scenario file is refused before anything runs.)"""
    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('plugins = ["nan_plugin"]\n')
    (proj / "nan_plugin.py").write_text(NAN_PLUGIN)
    spec = yaml.safe_load((SCENARIOS / "line_straight.yaml").read_text())
    spec["agents"]["lt0"]["controller"] = {"type": "nan_wheels"}
    (proj / "scenarios" / "nan_straight.yaml").write_text(yaml.safe_dump(spec))
    out = tmp_path / "out"
    p = kartci("run", "line_circle", "nan_straight", *QUICK, "-j", "2", "--out", out,
               "--baselines", baselines, cwd=proj)
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stdout + p.stderr
    summary = json.loads((out / "summary.json").read_text())["scenarios"]
    assert summary["nan_straight"]["status"] == "error"
    assert "non-finite state" in summary["nan_straight"]["error"]
    assert summary["line_circle"]["status"] == "new"
    assert (out / "report.html").exists() and (out / "junit.xml").exists()


@pytest.mark.long(reason="kartci runs end to end")
def test_a_run_over_its_time_limit_is_an_error(tmp_path: Path, baselines: Path) -> None:
    p = kartci("run", "line_straight", *QUICK, "--timeout-s", "0.01", "--out", tmp_path,
               "--baselines", baselines)
    assert p.returncode == 2
    assert "time limit: over 0.01 s wall clock" in p.stdout + p.stderr
    bad = kartci("run", "line_straight", "--timeout-s", "-1", "--out", tmp_path)
    assert bad.returncode == 2 and "--timeout-s" in bad.stderr
