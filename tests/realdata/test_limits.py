"""calibrate's honesty and the differential drive's limits: a value at its bound is flagged with
the bound, a parameter without an interval says why (never "+- inf"), and the base
controller's speed and acceleration limits shape the simulated TurtleBot3's motion."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from kartci.logs import msg
from kartci.project import current as active_project
from kartci.realdata.calibrate import Bound, Estimate, Fit, Param, estimate, with_values
from kartci.realdata.divergence import run_whole
from kartci.realdata.drive import read_drive
from kartci.realdata.importer import import_log
from kartci.realdata.plant import DiffDrive, Plant
from kartci.realdata.profile import CommandRole, load_profile, resolve_profile
from kartci.realdata.simreal import sim_setup

ROOT = Path(__file__).resolve().parents[2]
P = (Param("a", 1.0, 0.5, 2.0), Param("b", 2.0, 1.0, 4.0), Param("c", 3.0, 1.5, 6.0))


def test_a_value_at_its_bound_is_flagged_with_the_bound() -> None:
    rng = np.random.default_rng(0)
    jac, fun = rng.normal(size=(50, 3)), rng.normal(size=50)
    est = estimate(jac, fun, P, [0.5, 2.5, 6.0])
    assert [e.bound for e in est] == [Bound.LOWER, None, Bound.UPPER]
    assert est[2].note(P[2]) == "at its upper bound 6: widen it, or the model lacks something"
    assert all(e.ci95 is not None and e.ci95 > 0 for e in est)


def test_no_interval_says_why_instead_of_inf() -> None:
    rng = np.random.default_rng(1)
    jac = rng.normal(size=(50, 3))
    jac[:, 1] = 0.0  # the log does not excite b
    jac[:, 2] = 3.0 * jac[:, 0]  # c acts exactly as a does
    est = estimate(jac, rng.normal(size=50), P, [1.0, 2.0, 3.0])
    assert est[1].ci95 is None and est[1].interval() == (
        "not identifiable from this log: the divergence does not change with it (the log "
        "does not excite it)")
    assert est[0].ci95 is None and "cannot be told apart from c's" in est[0].why
    assert est[2].ci95 is None and "cannot be told apart from a's" in est[2].why
    fit = Fit(P, est, {}, {}, 1)
    doc = json.loads(json.dumps(fit.to_json(), allow_nan=False))  # no inf, no NaN
    assert doc["params"]["b"]["ci95"] is None
    assert doc["params"]["b"]["not_identifiable"].startswith("the divergence does not")


def _vec(x: float, y: float, z: float) -> object:
    return msg("geometry_msgs/msg/Vector3", x=x, y=y, z=z)


def _cmd(v: float, w: float) -> object:
    return msg("geometry_msgs/msg/Twist", linear=_vec(v, 0.0, 0.0),
               angular=_vec(0.0, 0.0, w))


def test_the_base_controller_clamps_and_ramps_its_commands() -> None:
    role = CommandRole(topic="/cmd_vel", wheel_radius_m=0.05, wheel_separation_m=0.2,
                       max_speed_mps=0.3, max_accel_mps2=1.0, max_yaw_rate_radps=1.0)
    drive = DiffDrive(role)
    assert drive.every_tick
    drive.reset(0.1, 0.0)  # a window starts with the robot at 0.1 m/s
    speeds = []
    for k in range(30):  # 0.5 m/s and 2 rad/s asked, every 20 ms
        ((_, js),) = drive("cmd_vel", _cmd(0.5, 2.0), k * 20_000_000)
        left, right = js.velocity * 0.05
        speeds.append(((left + right) / 2, (right - left) / 0.2))
    v = [s[0] for s in speeds]
    assert v[0] == pytest.approx(0.1)  # no time has passed
    assert v[1] == pytest.approx(0.12) and v[5] == pytest.approx(0.2)  # 1 m/s^2 x 20 ms
    assert v[-1] == pytest.approx(0.3)  # then the speed limit
    assert all(s[1] == pytest.approx(1.0) for s in speeds[1:])  # no yaw acceleration limit
    # without limits: the command as the kinematics turn it into wheel speeds, once
    free = DiffDrive(CommandRole(topic="/cmd_vel", wheel_radius_m=0.05, wheel_separation_m=0.2))
    ((_, js),) = free("cmd_vel", _cmd(0.5, 2.0), 0)
    assert not free.every_tick and list(js.velocity) == [(0.5 - 0.2) / 0.05, (0.5 + 0.2) / 0.05]


def test_profile_parameters_are_set_for_calibration(tmp_path: Path) -> None:
    path = tmp_path / "p.yaml"
    path.write_text("pose: {topic: /odom}\ncommands: {topic: /cmd_vel, max_speed_mps: 0.3}\n")
    p = with_values(load_profile(path, active_project()), {"commands.max_speed_mps": 0.25})
    assert p.commands is not None and p.commands.max_speed_mps == 0.25


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_a_speed_limit_caps_the_simulated_turtlebot(bags: Path, tmp_path: Path) -> None:
    """The TurtleBot3 bag commands up to 0.5 m/s; with a 0.2 m/s limit in its base controller
    the simulated robot, driven by the same commands over the whole log, stays below it."""
    log = bags / "turtlebot3_gazebo_cmd_odom_scan.bag"
    profile, info = resolve_profile(log, ROOT / "profiles" / "turtlebot3.yaml", active_project())
    imported = tmp_path / "tb3.mcap"
    import_log(log, profile, {r: i.msgtype for r, i in info.items()}, imported)
    drive = read_drive(imported, profile.agent)
    top = {}
    for limit in (None, 0.2):
        limited = with_values(profile, {"commands.max_speed_mps": limit} if limit else {})
        limited = with_values(limited, {"commands.max_accel_mps2": 1.0} if limit else {})
        setup = sim_setup(limited, None, [], active_project())
        plant = Plant(setup.scenario, drive, setup.convert)
        try:
            _, states = run_whole(plant, drive)
        finally:
            plant.close()
        top[limit] = float(np.max(np.hypot(states[:, 3], states[:, 4])))
    assert top[None] > 0.4
    assert top[0.2] < 0.21
    assert math.isfinite(top[0.2])


def test_estimate_type_holds_its_parts() -> None:
    e = Estimate(1.0, 0.1, "", Bound.LOWER)
    assert e.interval() == "+- 0.1" and "lower bound 0.5" in e.note(P[0])
