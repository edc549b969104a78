"""The ETH go-kart (seed 000) as a robot kind: registered as `gokart` (entry point).

Public for a team's own kart controller: the command (`KartInput`), the steering map
(`wheel_angles`, `column_for_wheel_angle`, `steer_for_turn_rate`); the outline is in
`kartci.robots.gokart.outline` (`outline`, `half_width_m`, `footprint_m`: from the kart's URDF).
"""

from kartci.core import RobotKind, SimReal, WheelOdometry, lazy
from kartci.robots.gokart import messages
from kartci.robots.gokart.faults import FAULTS
from kartci.robots.gokart.params import GokartModel, KartSensors, axle_distance_m
from kartci.robots.gokart.steering import (
    STEERING_RATIO,
    KartInput,
    column_for_wheel_angle,
    speed_to_pedals,
    steer_for_turn_rate,
    wheel_angles,
)


def odometry(model: GokartModel) -> WheelOdometry:
    """The kart's wheel odometry: its driven rear wheels."""
    return WheelOdometry(("rear_left_wheel_joint", "rear_right_wheel_joint"),
                         model.rear_wheel_radius_m)


ROBOT = RobotKind("gokart", GokartModel, lazy("kartci.robots.gokart.robot:KartRobot"),
                  ("laps", "race", "handling"), lazy("kartci.robots.gokart.plots:kart_plots"),
                  "the ETH go-kart (seed 000): steering map, two rear motors, lidar, IMU",
                  KartSensors, lazy("kartci.robots.gokart.outline:outline"),
                  publishes=("odom", "joint_states", "imu", "velodyne_points",
                             "camera/image_raw", "collision"),
                  accepts=("cmd", "ackermann_cmd", "cmd_vel"), odometry=odometry,
                  joystick=lazy("kartci.robots.gokart.joy:joystick"),
                  replay=lazy("kartci.robots.gokart.drivers:replay"),
                  simreal=SimReal("kart_simreal", (
                      "geometry_msgs/msg/Twist", "geometry_msgs/msg/TwistStamped",
                      "ackermann_msgs/msg/AckermannDriveStamped", "kartci_msgs/msg/KartCommand")),
                  control=lazy("kartci.robots.gokart.control:control"),
                  flatteners=messages.FLATTENERS, wall_clock=messages.WALL_CLOCK,
                  warnings=lazy("kartci.robots.gokart.stability:speed_warnings"),
                  commands=messages.COMMANDS,
                  figures=lazy("kartci.robots.gokart.plots:kart_figures"), faults=FAULTS)


__all__ = ["ROBOT", "STEERING_RATIO", "GokartModel", "KartInput", "KartSensors",
           "axle_distance_m", "column_for_wheel_angle", "speed_to_pedals", "steer_for_turn_rate",
           "wheel_angles"]
