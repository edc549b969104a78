"""Open-loop replay: a recorded run through its own controller reproduces the recorded outputs
exactly; a test agent registered by a project plugin module is compared with a reference, and a
deliberately changed agent is flagged (exit 1), unless within a stated tolerance."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import QUICK, kartci

import kartci as kartci_api
from kartci.errors import SpecError
from kartci.realdata.openloop import open_loop

AGENT = '''
import numpy as np
from pydantic import Field
from kartci.core import Controller, ControllerParams, register


class EchoParams(ControllerParams):
    """An odometry echo with an offset."""
    offset_m: float = Field(OFFSET, description="added to x, m")


class Echo:
    """Publishes its latest odometry as an estimate, shifted by offset_m."""
    inputs = ("odom",)

    def __init__(self, params, ctx):
        self.period_s, self.offset, self.last = 0.02, params.offset_m, None

    def on_message(self, topic, message):
        self.last = message

    def step(self, t_ns):
        if self.last is None:
            return []
        self.last.pose.pose.position.x += self.offset
        return [("estimate", self.last)]


register(Controller("odom_echo", EchoParams, Echo, (), "test agent"))
'''


@pytest.fixture(scope="module")
def line_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A 3 s line-tracker run driven by line_pid: its log holds inputs and outputs."""
    out = tmp_path_factory.mktemp("run")
    overrides = [QUICK[i + 1] for i in range(0, len(QUICK), 2)]
    return Path(kartci_api.run("line_straight", overrides=overrides, out=out,
                               baselines=out).log)


def test_a_recorded_run_through_its_controller_is_reproduced_exactly(line_run: Path,
                                                                    tmp_path: Path) -> None:
    results = open_loop(line_run, "line_pid", None, None, {}, tmp_path)
    wheel = next(r for r in results if r.topic == "/lt0/wheel_cmd")
    assert wheel.compared > 40 and wheel.differing == 0 and not wheel.note


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_a_project_agent_is_gated_on_its_outputs(line_run: Path, tmp_path: Path) -> None:
    project = tmp_path / "team"
    project.mkdir()
    (project / "kartci.toml").write_text('plugins = ["team_agents"]\n', encoding="utf-8")
    module = project / "team_agents.py"
    module.write_text(AGENT.replace("OFFSET", "0.0"), encoding="utf-8")
    ref = tmp_path / "ref"
    first = kartci("replay", line_run, "--open-loop", "--agent", "odom_echo", "--out", ref,
                   cwd=project)
    # the run log holds no /lt0/estimate to compare with: flagged
    assert first.returncode == 1 and "the reference has 0" in first.stdout
    module.write_text(AGENT.replace("OFFSET", "0.001"), encoding="utf-8")  # a code change
    changed = kartci("replay", line_run, "--open-loop", "--agent", "odom_echo", "--reference",
                     ref / "openloop.mcap", "--out", tmp_path / "changed", cwd=project)
    assert changed.returncode == 1
    assert "pose.pose.position.x by 0.001" in changed.stdout
    tolerated = kartci("replay", line_run, "--open-loop", "--agent", "odom_echo", "--reference",
                       ref / "openloop.mcap", "--tolerance", "pose.pose.position.x=0.002",
                       "--out", tmp_path / "tolerated", cwd=project)
    assert tolerated.returncode == 0, tolerated.stdout


def test_unknown_agent_is_refused(line_run: Path, tmp_path: Path) -> None:
    with pytest.raises(SpecError, match="unknown controller 'nope'"):
        open_loop(line_run, "nope", None, None, {}, tmp_path)
