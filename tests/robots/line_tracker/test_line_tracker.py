"""Physics outcomes of the line tracker, driven through its wheel joints."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kartci.metrics import compute
from kartci.project import current as active_project
from kartci.robots.line_tracker.body import LineTracker
from kartci.scenario import load_scenario
from kartci.sim import simulate
from kartci.worlds.line_lab.world import LineLab as World

DT = 0.002


def _robot() -> tuple[World, LineTracker]:
    spec = load_scenario("line_straight", project=active_project())
    world = World(spec.world, DT)
    robot = LineTracker(world.client, spec.agents["lt0"], spec.world,  # type: ignore[arg-type]
                        active_project().root / "models" / "line_tracker", DT)
    return world, robot


def _drive(world: World, robot: LineTracker, seconds: float) -> list[tuple[float, float]]:
    out = []
    for _ in range(round(seconds / DT)):
        robot.pre_step()
        world.step()
        out.append(robot.wheel_speeds())
    return out


def test_wheels_answer_with_a_first_order_lag_of_0_1_s() -> None:
    world, robot = _robot()
    try:
        robot.command(5.0, 5.0)
        speeds = np.array(_drive(world, robot, 0.6))[:, 0]
    finally:
        world.close()
    t63 = (np.argmax(speeds >= 5.0 * (1 - math.exp(-1))) + 1) * DT
    assert t63 == pytest.approx(0.1, abs=0.01)
    assert speeds[-1] == pytest.approx(5.0, rel=0.02)


def test_wheel_speed_saturates_at_18_46_rad_s() -> None:
    world, robot = _robot()
    try:
        robot.command(40.0, -40.0)
        speeds = np.array(_drive(world, robot, 1.0))
    finally:
        world.close()
    assert speeds[-1, 0] == pytest.approx(18.46, rel=0.02)
    assert speeds[-1, 1] == pytest.approx(-18.46, rel=0.02)
    assert np.abs(speeds).max() <= 18.46 * 1.02


def test_equal_wheel_speeds_drive_straight_at_r_omega() -> None:
    world, robot = _robot()
    try:
        start = robot.state()
        robot.command(2.857, 2.857)  # 0.1 m/s with r = 0.035 m
        _drive(world, robot, 3.0)
        end = robot.state()
    finally:
        world.close()
    assert end.v_body[0] == pytest.approx(0.1, rel=0.03)
    assert end.xyz[1] - start.xyz[1] == pytest.approx(0.0, abs=0.002)
    assert end.xyz[0] - start.xyz[0] == pytest.approx(0.1 * 3.0 - 0.1 * 0.1, rel=0.05)


def test_sonar_stops_the_robot_before_an_obstacle(tmp_path: Path) -> None:
    """HC-SR04 below 0.1 m gates the wheels (seed TestSensor.cc, cb4)."""
    spec = load_scenario("line_straight", ["duration_s=16",
                                           "world.obstacles=[{center_m: [1.2, 0.0]}]"],
                                           project=active_project())
    log = tmp_path / "run.mcap"
    simulate(spec, log)
    from kartci.logs import tables

    t = tables(log, ["/lt0/sonar", "/lt0/odom", "/lt0/controller/state"])
    sonar, odom, state = t["/lt0/sonar"], t["/lt0/odom"], t["/lt0/controller/state"]
    assert state["sonar_stop"].any()
    first_stop = sonar["range"][state["sonar_stop"].to_numpy()].iloc[0]
    assert first_stop < 0.1
    assert first_stop == pytest.approx(0.1, abs=0.01)
    # it stays stopped: the front of the sonar is ~0.1 m from the box face (1.15 m)
    sonar_x = odom["x"].iloc[-1] + 0.116
    assert 1.15 - sonar_x == pytest.approx(0.1, abs=0.015)
    assert abs(odom["vx"].iloc[-1]) < 0.005
    _, m = compute(log)
    assert m["line_lost"].value == 0.0


def _frames(*sets: str) -> list[tuple[int, float, float]]:
    """(t_ns, left, right) of every line_sensor message in 1 s of line_straight."""
    from kartci.sim.session import Session

    out = []
    with Session(load_scenario("line_straight", ["duration_s=1", *sets],
                               project=active_project())) as s:
        r = s.reset()
        while True:
            out += [(r.t_ns, m.left, m.right) for topic, m in r.messages
                    if topic == "/lt0/line_sensor"]
            if r.done:
                break
            r = s.step()
    return out


def test_cameras_run_on_their_own_clock_and_can_lag_a_frame() -> None:
    """update_rate_hz 17 (annex model.sdf) gives 17 frames a second whatever the control period;
    latency_frames 1 publishes each image one frame late."""
    cam = "agents.lt0.sensors.line_sensor"
    now = _frames(f"{cam}.update_rate_hz=17")
    late = _frames(f"{cam}.update_rate_hz=17", f"{cam}.latency_frames=1")
    assert len(now) == 18  # t = 0, 1/17, ..., 16/17 s and 1 s
    assert [t for t, *_ in now] == [round(math.ceil(k / 17 / DT - 1e-9) * DT * 1e9)
                                   for k in range(17)] + [1_000_000_000]
    # both runs see the same first image; one frame later the lagging one still shows it
    assert late[0][1:] == late[1][1:] == now[0][1:] != now[1][1:]
    assert late[1][0] == now[1][0]
    assert len(_frames()) == math.floor(1 / 0.06) + 1  # default: a frame per control tick
