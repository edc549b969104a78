"""The line tracker as vectors for a learning loop (`kartci.gym`): its wheel-speed command and
its odometry, line-sensor luminances and measured wheel speeds."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from kartci.core import Channel, ControlSpace, odometry_channels, odometry_values
from kartci.logs import header, msg
from kartci.robots.line_tracker.metrics import LineMetricsParams
from kartci.robots.line_tracker.params import LineTrackerModel

LUMINANCE_BOUNDS = (-1.0, 2.0)  # line-sensor channels: 0 black .. 1 white, plus sensor noise
YAW_RATE_BOUND_RADPS = 50.0  # odometry yaw-rate channel's bound, rad/s
PREVIEW_M = (0.05, 0.1, 0.2)  # course curvature ahead, m (the robot is 0.2 m long)


def control(model: LineTrackerModel) -> ControlSpace:
    """`wheel_cmd` (JointState velocities, rad/s: left, right) within the wheel speed limit;
    observed: `odom`, `line_sensor` and the wheels' speeds (`joint_states`)."""
    w = model.wheel_speed_limit_radps
    speed = 2.0 * w * model.wheel_radius_m  # m/s, twice the fastest straight run

    def build(values: tuple[float, ...], t_ns: int, name: str) -> Any:
        return msg("sensor_msgs/msg/JointState", header=header(t_ns, f"{name}/base_link"),
                   name=[], position=np.zeros(0), effort=np.zeros(0),
                   velocity=np.array(values[:2], dtype=float))

    def read(latest: Mapping[str, Any]) -> tuple[float, ...]:
        line, joints = latest.get("line_sensor"), latest.get("joint_states")
        lum = (float(line.left), float(line.right)) if line is not None else (0.0, 0.0)
        spin = (float(joints.velocity[0]), float(joints.velocity[1])) if joints is not None \
            else (0.0, 0.0)
        return (*odometry_values(latest.get("odom")), *lum, *spin)

    def line_lost(values: Mapping[str, float]) -> bool:
        """Lost control: the sensor point (ahead of base_link) farther from the line than the
        line metrics' `lost_threshold_m`, the sensor's range (as `line_lost` counts it)."""
        if "lateral_m" not in values:
            return False
        ahead = model.sensor_point_x_m * math.sin(values["heading_error_rad"])
        return abs(values["lateral_m"] + ahead) > LineMetricsParams().lost_threshold_m

    low, high = LUMINANCE_BOUNDS
    return ControlSpace(
        "wheel_cmd", (Channel("left_wheel_radps", -w, w), Channel("right_wheel_radps", -w, w)),
        build, ("odom", "line_sensor", "joint_states"),
        (*odometry_channels(speed, YAW_RATE_BOUND_RADPS), Channel("line_left", low, high),
         Channel("line_right", low, high), Channel("left_wheel_spin_radps", -2 * w, 2 * w),
         Channel("right_wheel_spin_radps", -2 * w, 2 * w)), read, PREVIEW_M, line_lost)
