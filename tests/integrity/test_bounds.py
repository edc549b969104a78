"""Issue 24, defect 9: bad input that used to run (or hang) instead of failing with one line:
a huge `sweep:`, numbers far outside physics, agent names that are not ROS 2 names."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import kartci
from typer.testing import CliRunner

from kartci.cli import app
from kartci.project import current as active_project
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


def test_replicas_count_against_the_cap(tmp_path: Path) -> None:
    """200 points x 100 replicas are 20,000 runs: refused before any is expanded, as a sweep
    over the cap is (each replica is a run, a folder and a process of its own)."""
    values = "[" + ", ".join(str(i) for i in range(200)) + "]"
    path = _scenario(tmp_path, f"sweep:\n  seed: {values}\n")
    p = kartci("run", path, "--repeat", "100", "--out", tmp_path / "out")
    assert p.returncode == 2
    assert p.stderr == ("kartci: error: 200 runs x 100 replicas = 20,000 runs, more than the "
                        "10,000 allowed; split the command\n")
    assert not (tmp_path / "out").exists()


def test_sweep_validation_is_reported_point_by_point(tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """Each validated point reaches the progress callback as it is validated, and the CLI
    prints a line every SWEEP_LINE_EVERY points outside a terminal, before any run starts."""
    seen: list[tuple[int, int]] = []
    jobs = expand([str(_scenario(tmp_path))], [],
                  active_project(), ["seed=1,2", "agents.lt0.controller.kp=5,6,7"],
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


def test_a_start_far_off_the_line_is_refused_with_its_bound(tmp_path: Path) -> None:
    """`start.lateral_m: 1e308` ran a robot at 1e308 m: now one line with the key, the bound
    and its unit (a value from a file is never echoed), exit 2, nothing run."""
    path = _scenario(tmp_path, "    start: {lateral_m: 1.0e+308}\n")
    p = kartci("run", path, "--out", tmp_path / "out")
    assert p.returncode == 2
    assert p.stderr == (f"kartci: error: {path}:8:13: agents.lt0.start.lateral_m: must be at most "
                        "100 m\n")
    assert not (tmp_path / "out").exists()


def test_a_speed_command_beyond_physics_is_refused_with_its_bound(tmp_path: Path) -> None:
    """`v1_mps: 1e308` ran the controller with it: now refused the same way."""
    path = _scenario(tmp_path).with_name("fast.yaml")
    path.write_text(SCENARIO.replace("{type: line_pid}", "{type: line_pid, v1_mps: 1.0e+308}"))
    p = kartci("run", path, "--out", tmp_path / "out")
    assert p.returncode == 2
    assert p.stderr == (f"kartci: error: {path}:7:34: agents.lt0.controller.v1_mps: must be at "
                        "most 100 m/s\n")


def test_a_start_beside_the_track_is_refused_where_the_track_is_known(tmp_path: Path) -> None:
    """The track's width is known once the world has read it: a kart started 50 m beside the
    hall's centreline is a failed run with the reason, exit 2 (within the model's 100 m)."""
    p = kartci("run", "kart_manual", "--set", "duration_s=0.1", "--set",
               "agents.kart0.start.lateral_m=50", "--out", tmp_path / "out")
    assert p.returncode == 2
    assert ("ERROR: start.lateral_m: 50 m is off the track track.csv at along_m 0 m: it must "
            "be within -2.00 m .. 2.00 m of the centreline there") in p.stdout


def test_an_agent_name_that_is_not_a_ros_name_is_refused(tmp_path: Path) -> None:
    """An agent named `../../etc` recorded topics `/../../etc/odom`: names are ROS 2 name
    tokens now, checked before anything runs."""
    path = tmp_path / "etc.yaml"
    path.write_text(SCENARIO.replace("  lt0:", "  ../../etc:"))
    p = kartci("run", path, "--out", tmp_path / "out")
    assert p.returncode == 2
    assert p.stderr == (f'kartci: error: {path}:4:1: agents: agent name "../../etc" is not a ROS 2 '
                        "name token: a letter, then letters, digits and single underscores, not "
                        "ending in one, at most 64 characters (e.g. kart0)\n")
    assert not (tmp_path / "out").exists()
