"""A team's own kartci plugins, kept outside kartci: a pure-pursuit kart driver that publishes
the standard ackermann_msgs/AckermannDriveStamped, and a cornering metric.

Nothing here reaches into kartci's internals: the driver reads messages (its odometry and the
track, published once as CSV text on /kartci/track) and publishes a message; the metric reads
the run log's odometry table.
"""

from __future__ import annotations

import io
import math
from typing import Any, Literal

import numpy as np
from pydantic import Field

from kartci.core import (
    AgentContext,
    Controller,
    ControllerParams,
    Direction,
    Metric,
    MetricDef,
    MetricSet,
)
from kartci.logs import header, msg
from kartci.metrics import ScoreContext

TRACK = "/kartci/track"


class PurePursuitParams(ControllerParams):
    """Pure pursuit on the track's centreline at a speed set by the curvature ahead."""

    type: Literal["pure_pursuit"] = "pure_pursuit"
    period_s: float = Field(0.02, gt=0.0, description="control period, s")
    lookahead_m: float = Field(3.0, gt=0.0, description="distance to the aim point, m")
    speed_mps: float = Field(5.0, gt=0.0, description="top speed, m/s")
    max_lateral_accel_mps2: float = Field(3.0, gt=0.0, description="cornering limit, m/s^2")
    wheelbase_m: float = Field(1.206, gt=0.0, description="axle distance of the kart, m")


class PurePursuit:
    """Steers towards the centreline point `lookahead_m` ahead (Coulter, CMU-RI-TR-92-01)."""

    inputs: tuple[str, ...] = ("odom", TRACK)

    def __init__(self, params: PurePursuitParams, ctx: AgentContext) -> None:
        self.p, self.period_s = params, params.period_s
        self.xy: np.ndarray | None = None  # centreline points, m
        self.pose: tuple[float, float, float] | None = None

    def on_message(self, topic: str, message: Any) -> None:
        """Keep the centreline points (from the track's CSV) and the pose (m, rad) from odometry."""
        if topic == TRACK:
            rows = np.loadtxt(io.StringIO(message.data), delimiter=",", comments="#", ndmin=2)
            self.xy = rows[:, :2]
        elif topic == "odom":
            p, q = message.pose.pose.position, message.pose.pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            self.pose = (p.x, p.y, yaw)

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        """Steer towards the aim point at the speed the turn allows (lateral acceleration limit);
        nothing until both the track and a pose have arrived."""
        if self.xy is None or self.pose is None:
            return []
        x, y, yaw = self.pose
        xy = self.xy
        seg = np.hypot(*np.diff(np.vstack([xy, xy[:1]]), axis=0).T)
        i = int(np.argmin(np.hypot(xy[:, 0] - x, xy[:, 1] - y)))
        j, ahead = i, 0.0
        while ahead < self.p.lookahead_m:  # walk the centreline to the aim point
            ahead += seg[j]
            j = (j + 1) % len(xy)
        alpha = math.atan2(xy[j, 1] - y, xy[j, 0] - x) - yaw
        steer = math.atan2(2 * self.p.wheelbase_m * math.sin(alpha), self.p.lookahead_m)
        curvature = abs(2 * math.sin(alpha) / self.p.lookahead_m)
        speed = min(self.p.speed_mps,
                    math.sqrt(self.p.max_lateral_accel_mps2 / max(curvature, 1e-3)))
        return [("ackermann_cmd", msg(
            "ackermann_msgs/msg/AckermannDriveStamped", header=header(t_ns, "base_link"),
            drive=msg("ackermann_msgs/msg/AckermannDrive", steering_angle=steer,
                      steering_angle_velocity=0.0, speed=speed, acceleration=0.0, jerk=0.0)))]


def cornering(ctx: ScoreContext, params: Any) -> list[Metric]:
    """Peak and 95th-percentile lateral acceleration (speed x yaw rate), from odometry."""
    odom = ctx.odom
    lateral = np.abs(odom["vx"].to_numpy() * odom["wz"].to_numpy())
    return [Metric("lateral_accel_max_mps2", float(lateral.max()), "m/s^2"),
            Metric("lateral_accel_p95_mps2", float(np.percentile(lateral, 95)), "m/s^2")]


CONTROLLER = Controller("pure_pursuit", PurePursuitParams, PurePursuit, ("gokart",),
                        "pure pursuit on the centreline, AckermannDriveStamped out")
CORNERING = MetricSet(
    "cornering",
    {"lateral_accel_max_mps2": MetricDef("m/s^2", Direction.LOWER, 0.2, 0.05,
                                         "largest lateral acceleration"),
     "lateral_accel_p95_mps2": MetricDef("m/s^2", Direction.LOWER, 0.1, 0.05,
                                         "95th percentile of lateral acceleration")},
    cornering, description="lateral acceleration from odometry")
