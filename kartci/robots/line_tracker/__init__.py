"""The line tracker (seed 001) as a robot kind: registered as `line_tracker` (entry point)."""

from kartci.core import RobotKind, SimReal, lazy
from kartci.robots.line_tracker import messages
from kartci.robots.line_tracker.faults import FAULTS
from kartci.robots.line_tracker.params import LineTrackerModel, LineTrackerSensors

ROBOT = RobotKind("line_tracker", LineTrackerModel,
                  lazy("kartci.robots.line_tracker.robot:LineTrackerRobot"), ("line_tracking",),
                  lazy("kartci.robots.line_tracker.plots:line_plots"),
                  "the differential-drive line tracker of seed 001", LineTrackerSensors,
                  publishes=("odom", "joint_states", "line_sensor", "sonar"),
                  accepts=("wheel_cmd",),
                  simreal=SimReal("diffdrive_simreal", ("geometry_msgs/msg/Twist",
                                                        "geometry_msgs/msg/TwistStamped"),
                                  wheel_speeds=True),
                  control=lazy("kartci.robots.line_tracker.control:control"),
                  flatteners=messages.FLATTENERS,
                  figures=lazy("kartci.robots.line_tracker.plots:line_figures"),
                  faults=FAULTS)
