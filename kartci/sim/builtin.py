"""kartci's own robot kinds and worlds, registered through entry points like any team's."""

from __future__ import annotations

from kartci.plugins import RobotKind, WorldKind, lazy
from kartci.spec.models import GokartModel, HallWorld, LineLabWorld, LineTrackerModel

GOKART = RobotKind("gokart", GokartModel, lazy("kartci.sim.robots:KartRobot"),
                   ("laps", "race"), lazy("kartci.report.data:kart_plots"),
                   "the ETH go-kart (seed 000): steering map, two rear motors, lidar, IMU")
LINE_TRACKER = RobotKind("line_tracker", LineTrackerModel,
                         lazy("kartci.sim.robots:LineTrackerRobot"), ("line_tracking",),
                         lazy("kartci.report.data:line_plots"),
                         "the differential-drive line tracker of seed 001")
LINE_LAB = WorldKind("line_lab", LineLabWorld, lazy("kartci.sim.line_lab:LineLab"),
                     "a white floor with one black line (straight or circle)")
HALL = WorldKind("hall", HallWorld, lazy("kartci.sim.hall:Hall"),
                 "an indoor hall with walls, pillars, floor zones and a closed track")
