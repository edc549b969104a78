"""A team adds a world kind the way kartci's own are added: a project plugin module registers a
`WorldKind` with its own parameters and simulated world (built on `kartci.worlds.track`, like the
hall and the circuit), and a scenario in it runs end to end through `kartci run`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import kartci

from kartci.logs import messages
from kartci.worlds.track import TRACK_TOPIC

CONE_PLUGIN = '''
"""A cone course: a TUMFTM track on open ground with a cone every `cone_spacing_m` outside
both edges (a karting school's training layout)."""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field

from kartci.core import WorldKind, WorldParams, lazy, register
from kartci.sim.blocks import Block
from kartci.worlds.track import TrackWorldParams
from kartci.worlds.track.world import TrackWorld


class ConeCourseWorld(TrackWorldParams):
    """A track marked by cones."""

    kind: Literal["cone_course"] = Field("cone_course", description="world kind: a cone course")
    cone_spacing_m: float = Field(1.2, gt=0.2, le=50.0, description="between cones, m")
    cone_size_m: float = Field(0.5, gt=0.05, le=2.0, description="a cone's base (square), m")
    cone_offset_m: float = Field(0.5, ge=0.0, le=10.0, description="cone centre beyond the "
                                 "track's edge, m")


class ConeCourse(TrackWorld):
    """The floor and the cones; no walls, no ceiling."""

    spec: ConeCourseWorld

    def __init__(self, spec: WorldParams, dt_s: float) -> None:
        assert isinstance(spec, ConeCourseWorld)
        self.spec = spec
        super().__init__(spec, dt_s, [], 1000.0)

    def build(self) -> int:
        spec, track = self.spec, self.track
        step = max(1, round(spec.cone_spacing_m / float(track.s[1] - track.s[0])))
        normal = np.column_stack([-np.sin(track.heading), np.cos(track.heading)])
        size = (spec.cone_size_m, spec.cone_size_m, 0.5)
        for side, sign, width in (("left", 1.0, track.w_left), ("right", -1.0, track.w_right)):
            at = track.xy + sign * normal * (width + spec.cone_offset_m)[:, None]
            self.blocks += [Block(f"cone_{side}_{i}", (float(x), float(y)), size)
                            for i, (x, y) in enumerate(at[::step])]
        left, right = track.bounds()
        pts = np.vstack([left, right])
        floor = self._floor(pts.min(axis=0) - 5.0, pts.max(axis=0) + 5.0, spec.floor_friction)
        for blk in self.blocks:
            self.names[self._box(blk.center, blk.size, blk.yaw)] = blk.name
        return floor


register(WorldKind("cone_course", ConeCourseWorld, lazy("cone_world:ConeCourse"),
                   "a track marked by cones outside both edges"))
'''

SCENARIO = """
description: A scripted kart steers hard right off the start straight into the cones
world: {kind: cone_course, track: tracks/club.csv}
duration_s: 5.0
seed: 1
agents:
  kart0:
    model: gokart
    controller:
      type: script
      steps:
        - {t_s: 0.0, accel_mps2: 3.0}
        - {t_s: 1.0, steering_rad: -1.7, accel_mps2: 2.0}
    sensors: {lidar: {enabled: false}}
criteria:
  collisions: {min: 1}
"""


@pytest.fixture
def project(tmp_path: Path) -> Path:
    """A team's project: the plugin module named in kartci.toml, one scenario in the world."""
    proj = tmp_path / "proj"
    (proj / "scenarios").mkdir(parents=True)
    (proj / "kartci.toml").write_text('plugins = ["cone_world"]\n')
    (proj / "cone_world.py").write_text(CONE_PLUGIN)
    (proj / "scenarios" / "cone_crash.yaml").write_text(SCENARIO)
    return proj


def test_a_plugin_world_kind_is_listed_with_the_builtin_ones(project: Path) -> None:
    p = kartci("plugins", cwd=project)
    assert p.returncode == 0, p.stderr
    worlds = {line.split()[2]: line.split()[-1] for line in p.stdout.splitlines()
              if line.split()[:2] == ["world", "kind"]}
    assert worlds["cone_course"] == "cone_world"  # the module that registered it
    assert {"hall", "circuit", "line_lab"} <= set(worlds)


def test_a_scenario_runs_in_a_plugin_world_kind(project: Path, tmp_path: Path,
                                                baselines: Path) -> None:
    """The kart hits one of the plugin world's own cones: the world was simulated (its bodies
    collide, by their names), recorded (the scenario and the track are in the log, so the laps
    metrics score the progress along it) and judged (the criterion on collisions passes)."""
    out = tmp_path / "out"
    p = kartci("run", "cone_crash", "--out", out, "--baselines", baselines, cwd=project)
    assert p.returncode == 0, p.stdout + p.stderr
    summary = json.loads((out / "summary.json").read_text())["scenarios"]["cone_crash"]
    assert summary["status"] == "new", summary
    metrics = json.loads((out / "cone_crash" / "metrics.json").read_text())["metrics"]
    hits = metrics["collisions"]["events"]
    assert metrics["collisions"]["value"] == len(hits) >= 1
    assert all(h["other"].startswith("cone_right_") for h in hits), hits
    assert 2.0 < metrics["progress_m"]["value"] < 10.0  # along the club track, before the cone
    recorded = dict((topic, m) for topic, _, m in
                    messages(out / "cone_crash" / "run.mcap", [TRACK_TOPIC, "/kartci/scenario"]))
    assert json.loads(recorded["/kartci/scenario"].data)["world"]["kind"] == "cone_course"
    assert recorded[TRACK_TOPIC].data.startswith("#")  # the club track's CSV, header first
