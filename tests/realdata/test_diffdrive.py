"""A differential-drive robot (Twist commands, wheel odometry) against the simulation: the line
tracker stands in for it, its base controller's kinematics taken from the profile."""

from __future__ import annotations

from pathlib import Path

import pytest

from kartci.realdata.calibrate import Objective
from kartci.realdata.drive import read_drive
from kartci.realdata.importer import import_log
from kartci.realdata.profile import resolve_profile
from kartci.realdata.synthetic import synthetic_log

LAG = "agents.lt0.model.wheel_time_constant_s"


def test_wheel_lag_shows_in_the_divergence(tmp_path: Path) -> None:
    """A log of a robot whose wheels lag 0.3 s (nominal 0.1 s): the nominal model diverges,
    the true lag does not."""
    log = synthetic_log("diffdrive_simreal", [f"{LAG}=0.3"], 3.0, tmp_path / "dd.mcap",
                        noise_m=0.001, noise_rad=0.002)
    profile = tmp_path / "dd.yaml"
    profile.write_text("name: dd\npose: {topic: /lt0/odom}\n"
                       "commands: {topic: /lt0/cmd_vel, wheel_radius_m: 0.035, "
                       "wheel_separation_m: 0.15}\nrobot: {kind: line_tracker}\n",
                       encoding="utf-8")
    p, info = resolve_profile(log, profile)
    import_log(log, p, {r: i.msgtype for r, i in info.items()}, tmp_path / "imported.mcap")
    drive = read_drive(tmp_path / "imported.mcap", p.agent)
    nominal = Objective(p, None, [], (), drive, 1.0).metrics([])
    truth = Objective(p, None, [f"{LAG}=0.3"], (), drive, 1.0).metrics([])
    assert truth["simreal_ape_window_rmse_m"] < 0.5 * nominal["simreal_ape_window_rmse_m"]
    assert truth["simreal_speed_rms_mps"] < nominal["simreal_speed_rms_mps"]
    assert truth["simreal_ape_window_rmse_m"] == pytest.approx(0.0, abs=0.005)


def test_turtlebot_profile_names_its_kinematics(bags: Path) -> None:
    p, info = resolve_profile(bags / "turtlebot3_gazebo_cmd_odom_scan.bag",
                              Path(__file__).parents[2] / "profiles" / "turtlebot3.yaml")
    assert info["commands"].msgtype == "geometry_msgs/msg/Twist"
    assert p.commands is not None and p.commands.wheel_separation_m == 0.16
