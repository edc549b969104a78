"""The ETH go-kart (seed 000) as a robot kind: registered as `gokart` (entry point)."""

from kartci.core import RobotKind, lazy
from kartci.robots.gokart.params import GokartModel, KartSensors

ROBOT = RobotKind("gokart", GokartModel, lazy("kartci.robots.gokart.robot:KartRobot"),
                  ("laps", "race"), lazy("kartci.robots.gokart.plots:kart_plots"),
                  "the ETH go-kart (seed 000): steering map, two rear motors, lidar, IMU",
                  KartSensors)
