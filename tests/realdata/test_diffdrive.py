"""A differential-drive robot (Twist commands, wheel odometry) against the simulation: the line
tracker stands in for it, the Twist turned into wheel speeds with the profile's kinematics (the
real base controller's), so the robot's own wheel radius, separation and lag can be fitted."""

from __future__ import annotations

from pathlib import Path

import pytest

from kartci.project import current as active_project
from kartci.realdata.calibrate import calibrate_log
from kartci.realdata.profile import resolve_profile
from kartci.realdata.synthetic import synthetic_log

MODEL = "agents.lt0.model"
TRUTH = {"wheel_radius_m": 0.037, "wheel_separation_m": 0.16, "wheel_time_constant_s": 0.15}


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_calibrate_recovers_wheel_radius_separation_and_lag(tmp_path: Path) -> None:
    """The base controller believes in the URDF's 0.035 m wheels 0.15 m apart; the robot's
    are 0.037 m and 0.16 m and lag 0.15 s (nominal 0.1 s)."""
    log = synthetic_log("diffdrive_simreal", [f"{MODEL}.{k}={v}" for k, v in TRUTH.items()],
                        4.0, tmp_path / "dd.mcap", active_project(), noise_m=0.001, noise_rad=0.002)
    profile = tmp_path / "dd.yaml"
    profile.write_text("name: dd\npose: {topic: /lt0/odom}\n"
                       "commands: {topic: /lt0/cmd_vel, wheel_radius_m: 0.035, "
                       "wheel_separation_m: 0.15}\nrobot: {kind: line_tracker}\n",
                       encoding="utf-8")
    fit = calibrate_log(log, profile, None, [], [f"model.{k}" for k in TRUTH], 1.0,
                        tmp_path / "cal", active_project())
    for (key, truth), value in zip(TRUTH.items(), fit.values, strict=True):
        assert value == pytest.approx(truth, rel=0.05), key
    assert (fit.after["simreal_ape_window_rmse_m"]
            < 0.5 * fit.before["simreal_ape_window_rmse_m"])


def test_turtlebot_profile_names_its_kinematics(bags: Path) -> None:
    p, info = resolve_profile(bags / "turtlebot3_gazebo_cmd_odom_scan.bag",
                              Path(__file__).parents[2] / "profiles" / "turtlebot3.yaml",
                              active_project())
    assert info["commands"].msgtype == "geometry_msgs/msg/Twist"
    assert p.commands is not None and p.commands.wheel_separation_m == 0.16
