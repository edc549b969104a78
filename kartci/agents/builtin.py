"""kartci's own controllers and nodes that are not a robot kind's, registered through entry
points like any team's (each kind registers its own: `kartci.robots.<kind>.controllers`).
Factories are imported on first use."""

from __future__ import annotations

from kartci.bridge.params import COMMAND_TYPES, ExternalController
from kartci.core import Controller, Node, RobotKind, lazy
from kartci.localization.params import LocalizationParams
from kartci.perception.params import DetectorParams


def commandable(kind: RobotKind) -> bool:
    """The bridge drives a kind that applies one of its command topics or reads a joystick."""
    topics = {*COMMAND_TYPES.values(), *kind.commands.values()}
    return kind.joystick is not None or bool(topics & set(kind.accepts))


def localizable(kind: RobotKind) -> bool:
    """Localization needs a lidar, an IMU and wheel odometry."""
    return kind.odometry is not None and {"imu", "joint_states", "velodyne_points"} <= set(
        kind.publishes)


def has_lidar(kind: RobotKind) -> bool:
    """The detector needs a lidar's scans."""
    return "velodyne_points" in kind.publishes


EXTERNAL = Controller("external", ExternalController,
                      lazy("kartci.bridge.middleware:external_agent"),
                      (), "a separate program (a ROS 2 stack) closed loop over Zenoh "
                      "(rmw_zenoh conventions) or DDS (rclpy in a relay process), in lockstep "
                      "with sim time", commandable)

LOCALIZATION = Node("localization", LocalizationParams,
                    lazy("kartci.localization.node:LocalizationNode"), (),
                    "lidar registration to the map (small_gicp) fused with wheels and gyro "
                    "(planar EKF): localization/odom, tf, deskewed cloud", localizable)
OBSTACLE_DETECTOR = Node("obstacle_detector", DetectorParams,
                         lazy("kartci.perception.node:ObstacleDetector"), (),
                         "lidar obstacles: map and ground removal, clusters, boxes, tracks, "
                         "static or dynamic (vision_msgs/Detection3DArray, markers)", has_lidar)
