"""Issue 24, defect 9: bad input that used to run (or hang) instead of failing with one line:
a huge `sweep:`, numbers far outside physics, agent names that are not ROS 2 names."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import kartci
from typer.testing import CliRunner

from kartci.cli import app
from kartci.runner import expand

SCENARIO = """\
description: a line tracker for a moment
world: line_lab/straight
duration_s: 0.05
agents:
  lt0:
    model: line_tracker
    controller: {type: line_pid}
"""


def _scenario(tmp_path: Path, extra: str = "") -> Path:
    path = tmp_path / "probe.yaml"
    path.write_text(SCENARIO + extra)
    return path


def test_a_sweep_over_the_cap_fails_before_any_point_is_expanded(tmp_path: Path) -> None:
    """1000 x 1000 x 1000 points: refused from the axis lengths alone, one line, exit 2,
    nothing written (it used to validate point after point, silently, for hours)."""
    values = "[" + ", ".join(str(i) for i in range(1000)) + "]"
    path = _scenario(tmp_path, f"sweep:\n  seed: {values}\n  agents.lt0.controller.kp: "
                               f"{values}\n  agents.lt0.controller.ki: {values}\n")
    p = kartci("run", path, "--out", tmp_path / "out")
    assert p.returncode == 2
    assert p.stderr == (f"kartci: error: scenario {path}: sweep: 1,000,000,000 points, more "
                        "than the 10,000 allowed; split the sweep\n")
    assert not (tmp_path / "out").exists()


def test_sweep_validation_is_reported_point_by_point(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """Each validated point reaches the progress callback as it is validated, and the CLI
    prints a line every SWEEP_LINE_EVERY points outside a terminal, before any run starts."""
    seen: list[tuple[int, int]] = []
    jobs = expand([str(_scenario(tmp_path))], [], ["seed=1,2", "agents.lt0.controller.kp=5,6,7"],
                  progress=lambda done, total: seen.append((done, total)))
    assert len(jobs) == 6
    assert seen == [(k, 6) for k in range(1, 7)]
    monkeypatch.setattr("kartci.cli.run.SWEEP_LINE_EVERY", 1)
    result = CliRunner().invoke(app, ["run", str(_scenario(tmp_path)), "--sweep", "seed=1,2",
                                      "--out", str(tmp_path / "out")], prog_name="kartci")
    lines = result.output.splitlines()
    assert lines[:2] == ["validated 1 of 2 sweep points", "validated 2 of 2 sweep points"]


def test_a_sweep_point_selected_twice_is_found(tmp_path: Path) -> None:
    """Duplicate labels are found in a set as the points stream (it was a count over the
    whole list for each label: quadratic in the number of points)."""
    p = kartci("run", _scenario(tmp_path), "--sweep", "seed=1,2,1", "--out", tmp_path / "out")
    assert p.returncode == 2
    assert p.stderr == "kartci: error: scenario selected twice: probe@seed=1\n"
