"""The rendered line camera's cheaper scene (ring arcs near the camera, a one-triangle floor)
gives exactly the pixels of the full scene."""

from __future__ import annotations

import math

import numpy as np

from kartci._bullet import pb
from kartci.project import current as active_project
from kartci.robots.line_tracker.body import LineTracker
from kartci.robots.line_tracker.params import LineSensorSpec
from kartci.robots.line_tracker.render import RenderScene, unseen_links
from kartci.robots.line_tracker.sensors import LineCamera
from kartci.scenario import load_scenario
from kartci.sim.urdf import fixed_frames, urdf_path
from kartci.worlds.line_lab import CircleCourse
from kartci.worlds.line_lab.world import LineLab

DT = 0.002
DOWN = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # x axis (view) down


def _poses() -> list[tuple[np.ndarray, np.ndarray]]:
    """Cameras along and across the ring, on and off arc boundaries (every 10 degrees), a few
    tilted, one looking at the horizon (the footprint is unbounded: every arc shown)."""
    course = load_scenario("line_circle", project=active_project()).world.course  # type: ignore[attr-defined]
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
    spec = load_scenario("line_circle", project=active_project())
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


def test_the_robots_own_cameras_never_see_its_chassis_or_wheels() -> None:
    """Hiding the links `unseen_links` names leaves the robot's own camera readings unchanged
    (robot placed around the ring, wheels turned); a near-180-degree camera sees everything."""
    spec = load_scenario("line_circle", project=active_project())
    agent = spec.agents["lt0"]
    urdf = urdf_path(agent.model)
    cams = [fixed_frames(urdf)[f"line_camera_{s}"] for s in ("left", "right")]
    assert unseen_links(urdf, cams, 2.9) == []
    names = unseen_links(urdf, cams, 1.2)
    assert sorted(names) == ["base_link", "left_wheel", "right_wheel"]
    sensor = LineSensorSpec(mode="rendered")
    labs = [LineLab(spec.world, DT), LineLab(spec.world, DT)]
    try:
        robots = [LineTracker(lab.client, agent, lab.spec, urdf.parent, DT) for lab in labs]
        cameras = [LineCamera(lab.client, sensor, lab.spec) for lab in labs]
        for name in names:
            pb.changeVisualShape(robots[1].body, robots[1].link_index[name],
                                 rgbaColor=[0, 0, 0, 0], physicsClientId=labs[1].client)
        start = robots[0].state()
        for k in range(8):
            readings = []
            for robot, camera in zip(robots, cameras, strict=True):
                robot.reset_pose(np.asarray(start.xyz) + np.array([0.01 * k, -0.02 * k, 0.0]),
                                 pb.getQuaternionFromEuler([0.0, 0.02 * k, 0.8 * k]))
                robot.spin(robot.wheels, [1.0, -1.0])
                pb.stepSimulation(physicsClientId=robot.client)  # wheels turn, body settles
                st = robot.state()
                readings.append([camera.luminance(*robot.frame_pose(f"line_camera_{s}", st))
                                 for s in ("left", "right")])
            assert readings[0] == readings[1]
    finally:
        for lab in labs:
            lab.close()
