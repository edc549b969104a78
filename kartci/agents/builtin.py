"""kartci's own controllers, registered through entry points like any team's. Factories are
imported on first use, so a line-tracker run never imports CasADi."""

from __future__ import annotations

from kartci.agents.params import (
                      CommandsController,
                      JoyDriverController,
                      ManualController,
                      ScriptController,
)
from kartci.bridge.params import ExternalController
from kartci.core import Controller, Node, lazy
from kartci.localization.params import LocalizationParams
from kartci.mpcc.params import MpccController
from kartci.perception.params import DetectorParams

KART = ("gokart",)

MANUAL = Controller("manual", ManualController, lazy("kartci.agents.kart:ManualAgent"), KART,
                    "a recorded joystick (sensor_msgs/Joy) through a mapping")
COMMANDS = Controller("commands", CommandsController, lazy("kartci.agents.kart:CommandsAgent"),
                      KART, "a recorded AckermannDriveStamped, Twist or TwistStamped stream")
SCRIPT = Controller("script", ScriptController, lazy("kartci.agents.kart:ScriptAgent"), KART,
                    "a fixed command timeline")
JOY_DRIVER = Controller("joy_driver", JoyDriverController, lazy("kartci.agents.kart:JoyDriver"),
                        KART, "a scripted human: pure pursuit expressed as joystick messages")
MPCC = Controller("mpcc", MpccController, lazy("kartci.agents.mpcc:MpccAgent"), KART,
                  "model predictive contouring control (CasADi / Ipopt)")
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
