"""kartci's own controllers and nodes that are not a robot kind's, registered through entry
points like any team's (each kind registers its own: `kartci.robots.<kind>.controllers`).
Factories are imported on first use."""

from __future__ import annotations

from kartci.bridge.params import ExternalController
from kartci.core import Controller, Node, lazy
from kartci.localization.params import LocalizationParams
from kartci.perception.params import DetectorParams

KART = ("gokart",)

EXTERNAL = Controller("external", ExternalController, lazy("kartci.bridge.agent:ExternalAgent"),
                      KART, "a separate program (a ROS 2 stack) closed loop over Zenoh, "
                      "rmw_zenoh conventions, in lockstep with sim time")

LOCALIZATION = Node("localization", LocalizationParams,
                    lazy("kartci.localization.node:LocalizationNode"), KART,
                    "lidar registration to the map (small_gicp) fused with wheels and gyro "
                    "(planar EKF): localization/odom, tf, deskewed cloud")
OBSTACLE_DETECTOR = Node("obstacle_detector", DetectorParams,
                         lazy("kartci.perception.node:ObstacleDetector"), KART,
                         "lidar obstacles: map and ground removal, clusters, boxes, tracks, "
                         "static or dynamic (vision_msgs/Detection3DArray, markers)")
