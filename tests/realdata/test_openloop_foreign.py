"""Open-loop replay of a foreign (real robot's) log: every way it cannot run is one line and
exit 2 naming what is missing, never an internal error."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest
from helpers import kartci

BAG = "turtlebot3_gazebo_cmd_odom_scan.bag"


def _one_line(proc: subprocess.CompletedProcess[str]) -> str:
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "internal error" not in lines[0], proc.stderr
    return str(lines[0])


def test_a_foreign_log_without_a_namespace_lists_its_topics(bags: Path, tmp_path: Path) -> None:
    line = _one_line(kartci("replay", bags / BAG, "--open-loop", "--agent", "localization",
                            "-o", tmp_path))
    assert "not a kartci run log (no /kartci/scenario)" in line
    assert "/scan (sensor_msgs/msg/LaserScan)" in line and "(--ns)" in line


@pytest.mark.long(reason="end-to-end runs of real or synthetic logs")
def test_a_robot_specific_agent_says_which_robots_it_runs_on(bags: Path, tmp_path: Path) -> None:
    for agent in ("localization", "line_pid"):
        line = _one_line(kartci("replay", bags / BAG, "--open-loop", "--agent", agent,
                                "--ns", "tb3", "-o", tmp_path))
        assert f"{agent} runs on " in line and "its kind is `recorded`" in line


def test_a_missing_log_is_named_as_missing(tmp_path: Path) -> None:
    line = _one_line(kartci("replay", tmp_path / "none.mcap", "--open-loop", "--agent",
                            "localization", "-o", tmp_path))
    assert line.endswith("none.mcap: no such file or directory")
