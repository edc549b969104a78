"""The kind-neutral agents (external, localization, obstacle_detector) state what they need of
a robot; the kinds say what they have, and the registry names the kinds that fit."""

from __future__ import annotations

from kartci import core
from kartci.agents.builtin import commandable, has_lidar, localizable
from kartci.core import RobotKind, RobotParams, WheelOdometry


def _kind(**facts: object) -> RobotKind:
    return RobotKind("team_bot", RobotParams, lambda ctx: None, **facts)  # type: ignore[arg-type]


def test_the_builtin_kinds_that_fit_are_named_as_before() -> None:
    assert core.CONTROLLERS.get("external").kinds() == ("gokart",)
    assert core.NODES.get("localization").kinds() == ("gokart",)
    assert core.NODES.get("obstacle_detector").kinds() == ("gokart",)
    assert core.CONTROLLERS.get("line_pid").kinds() == ("line_tracker",)  # named by its kind


def test_a_teams_kind_fits_by_what_it_has() -> None:
    lidar = ("odom", "imu", "joint_states", "velodyne_points")
    wheels = WheelOdometry(("left", "right"), 0.1)
    assert localizable(_kind(publishes=lidar, odometry=lambda p: wheels))
    assert not localizable(_kind(publishes=lidar))  # no wheel odometry
    assert not localizable(_kind(publishes=("odom", "imu"), odometry=lambda p: wheels))
    assert has_lidar(_kind(publishes=lidar)) and not has_lidar(_kind())
    assert commandable(_kind(accepts=("cmd_vel",)))
    assert not commandable(_kind(accepts=("wheel_cmd",)))


def test_the_kart_tells_localization_its_driven_wheels() -> None:
    from kartci.robots.gokart import GokartModel

    kart = core.ROBOTS.get("gokart")
    assert kart.odometry is not None
    model = GokartModel()
    assert kart.odometry(model) == WheelOdometry(
        ("rear_left_wheel_joint", "rear_right_wheel_joint"), model.rear_wheel_radius_m)
