"""A robot kind's command and observation as vectors of numbers: what a learning loop
(`kartci.gym`) steps a robot with, declared by the kind so that the loop names no kind.

A kind states one command topic it accepts, the numbers that command carries (with units and
ranges) and how to build its message from them, and the numbers an observation holds with the
topics they are read from. Every kind publishes `odom`; `odometry_channels` and
`odometry_values` are its six numbers (pose in the world frame, twist in base_link).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

POSITION_LIMIT_M = 1e4  # |x|, |y| bound of the odometry channels, m (any world here fits)


@dataclass(frozen=True)
class Channel:
    """One number of a command or an observation: its name (unit last, `accel_mps2`) and its
    range, low to high, in that unit."""

    name: str
    low: float
    high: float


# (values in channel order, t_ns, robot name) -> the command message
BuildCommand = Callable[[tuple[float, ...], int, str], Any]
# (latest message per input topic, absent before its first) -> values in channel order
ReadObservation = Callable[[Mapping[str, Any]], tuple[float, ...]]


@dataclass(frozen=True)
class ControlSpace:
    """A robot's command and observation as vectors (`RobotKind.control(params)` makes one).

    Attributes:
        topic: The command topic, relative to the robot's namespace (one of the kind's
            `accepts`).
        command: The command's numbers, in order.
        build: Turns values (one per `command` channel, in range) into the command message.
        inputs: Topics an observation is read from, relative to the robot's namespace.
        observation: The observation's numbers, in order.
        read: Turns the latest message of each input topic into values, one per channel.
        preview_m: Distances ahead along the world's course, m, at which a learning loop
            shows the course's curvature (what a driver of this robot's size looks ahead).
        lost: Whether the robot has lost control, from the observation's values by name
            (the course's among them where the world has one, `kartci.gym.course_channels`):
            a kart spinning, a line tracker whose sensor is off the line; None: never.
    """

    topic: str
    command: tuple[Channel, ...]
    build: BuildCommand
    inputs: tuple[str, ...]
    observation: tuple[Channel, ...]
    read: ReadObservation
    preview_m: tuple[float, ...] = ()
    lost: Callable[[Mapping[str, float]], bool] | None = None


def odometry_channels(speed_mps: float, yaw_rate_radps: float) -> tuple[Channel, ...]:
    """The six numbers of `odom`: x, y (m), yaw (rad) in the world frame; forward and left
    speed (m/s, bounded by `speed_mps`) and yaw rate (rad/s) in base_link."""
    p = POSITION_LIMIT_M
    return (Channel("x_m", -p, p), Channel("y_m", -p, p), Channel("yaw_rad", -math.pi, math.pi),
            Channel("vx_mps", -speed_mps, speed_mps), Channel("vy_mps", -speed_mps, speed_mps),
            Channel("yaw_rate_radps", -yaw_rate_radps, yaw_rate_radps))


def odometry_values(odom: Any) -> tuple[float, ...]:
    """`odometry_channels`' values from a nav_msgs/Odometry (zeros for None: none yet)."""
    if odom is None:
        return (0.0,) * 6
    p, q = odom.pose.pose.position, odom.pose.pose.orientation
    tw = odom.twist.twist
    yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    return (float(p.x), float(p.y), yaw, float(tw.linear.x), float(tw.linear.y),
            float(tw.angular.z))
