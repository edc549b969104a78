"""The kart as vectors for a learning loop (`kartci.gym`): the source document's command
(steering-column angle, motor acceleration, brake deceleration) and its odometry plus the steering
column."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from kartci.core import Channel, ControlSpace, odometry_channels, odometry_values
from kartci.robots.gokart.handling import HandlingParams
from kartci.robots.gokart.joy import kart_command
from kartci.robots.gokart.params import GokartModel
from kartci.robots.gokart.steering import KartInput

SPEED_BOUND_MPS = 50.0  # odometry speed channels' bound, m/s (well past any kart's)
YAW_RATE_BOUND_RADPS = 20.0  # odometry yaw-rate channel's bound, rad/s
PREVIEW_M = (2.0, 5.0, 10.0, 15.0, 20.0)  # course curvature ahead, m (2 s at 10 m/s)


def spinning(values: Mapping[str, float]) -> bool:
    """Lost control: the sideslip (odometry's vy against vx) beyond the handling metrics'
    spin threshold while moving faster than their `moving_mps` (one definition of a spin)."""
    limits = HandlingParams()
    vx, vy = values["vx_mps"], values["vy_mps"]
    return (math.hypot(vx, vy) > limits.moving_mps
            and abs(math.degrees(math.atan2(vy, abs(vx)))) > limits.spin_deg)


def control(model: GokartModel) -> ControlSpace:
    """`cmd` (kartci_msgs/KartCommand) from steering, acceleration and brake within the model's
    limits; observed: `odom` and the steering column's angle (`joint_states`)."""
    lo, hi = model.steering_limit_rad

    def build(values: tuple[float, ...], t_ns: int, name: str) -> Any:
        steering, accel, brake = values
        return kart_command(KartInput(steering, accel, brake), t_ns, f"{name}/base_link")

    def read(latest: Mapping[str, Any]) -> tuple[float, ...]:
        joints = latest.get("joint_states")
        column = 0.0
        if joints is not None and "steering_column" in joints.name:
            column = float(joints.position[list(joints.name).index("steering_column")])
        return (*odometry_values(latest.get("odom")), column)

    return ControlSpace(
        "cmd", (Channel("steering_rad", lo, hi), Channel("accel_mps2", 0.0, model.max_accel_mps2),
                Channel("brake_mps2", 0.0, model.max_brake_mps2)), build,
        ("odom", "joint_states"),
        (*odometry_channels(SPEED_BOUND_MPS, YAW_RATE_BOUND_RADPS),
         Channel("steering_column_rad", lo, hi)), read, PREVIEW_M, spinning)
