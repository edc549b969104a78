"""The rendered line camera's cheaper scene (ring arcs near the camera, a one-triangle floor)
gives exactly the pixels of the full scene."""

from __future__ import annotations

import math

import numpy as np

from kartci.robots.line_tracker.params import LineSensorSpec
from kartci.robots.line_tracker.render import RenderScene
from kartci.robots.line_tracker.sensors import LineCamera
from kartci.sim.line_lab import LineLab
from kartci.spec import load_scenario
from kartci.spec.models import CircleCourse

DT = 0.002
DOWN = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # x axis (view) down


def _poses() -> list[tuple[np.ndarray, np.ndarray]]:
    """Cameras along and across the ring, on and off arc boundaries (every 10 degrees), a few
    tilted, one looking at the horizon (the footprint is unbounded: every arc shown)."""
    course = load_scenario("line_circle").world.course  # type: ignore[attr-defined]
    assert isinstance(course, CircleCourse)
    cx, cy = course.center_m
    out = []
    for k, deg in enumerate(np.arange(0.0, 360.0, 7.3)):
        a = math.radians(deg)
        r = course.radius_m + 0.004 * math.sin(3 * k)
        tilt = 0.15 * math.sin(k)
        c, s = math.cos(tilt), math.sin(tilt)
        rot = DOWN @ np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        out.append((np.array([cx + r * math.cos(a), cy + r * math.sin(a), 0.0145]), rot))
    out.append((np.array([cx + course.radius_m, cy, 0.0145]), np.eye(3)))  # horizontal
    return out


def test_the_render_scene_gives_the_full_scenes_pixels() -> None:
    spec = load_scenario("line_circle")
    sensor = LineSensorSpec(mode="rendered")
    full, cheap = LineLab(spec.world, DT), LineLab(spec.world, DT)
    try:
        plain = LineCamera(full.client, sensor, full.spec)  # no lab: the whole scene
        scened = LineCamera(cheap.client, sensor, cheap.spec, cheap)
        shown = []
        for pos, rot in _poses():
            assert scened.luminance(pos, rot) == plain.luminance(pos, rot)
            shown.append(int(RenderScene.of(cheap).shown.sum()))
        assert max(shown[:-1]) <= 3  # looking down, only the arcs near the camera are drawn
        assert shown[-1] == len(RenderScene.of(cheap).bodies)  # at the horizon, all of them
        assert min(plain.luminance(p, r) for p, r in _poses()[:-1]) < 0.6  # the line is seen
    finally:
        full.close()
        cheap.close()
