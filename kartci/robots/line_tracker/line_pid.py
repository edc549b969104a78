"""The source document's P / PI line-tracking controller (TestSensor.cc in the annex), on
messages."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kartci.core import AgentContext, Outbox
from kartci.logs.types import base_link, header, msg
from kartci.robots.line_tracker.controllers import LinePidController
from kartci.robots.line_tracker.params import LineTrackerModel


class LinePid:
    """u2 = Kp * (-d) + Ki * integral; wL = (v1 - 0.06 u2) / r, wR = (v1 + 0.06 u2) / r.

    d is estimated from the camera difference only (Eq. 6.13); the controller never sees the
    true offset. Like the seed, the integral accumulates 0.01 * Ki * error per control step and
    the wheels stop while the sonar reads less than `stop_range_m`.
    """

    inputs: tuple[str, ...] = ("line_sensor", "sonar")

    def __init__(self, spec: LinePidController, ctx: AgentContext) -> None:
        assert isinstance(ctx.model, LineTrackerModel)  # Controller.build checked the kind
        self.spec, self.model = spec, ctx.model
        self.frame = base_link(ctx.name)
        self.period_s = spec.period_s
        self._left = self._right = 0.0
        self._range = math.inf
        self._integral = 0.0

    def on_message(self, topic: str, message: Any) -> None:
        """Keep the latest camera luminances (left, right) and sonar range (m)."""
        if topic == "line_sensor":
            self._left, self._right = message.left, message.right
        elif topic == "sonar":
            self._range = message.range

    def step(self, t_ns: int) -> Outbox:
        """Wheel speeds (rad/s) from the offset estimate, zero while the sonar reads less than
        `stop_range_m`; and the controller's state, for the log."""
        s = self.spec
        y = self._left - self._right
        d = s.slope_m * y + s.offset_m
        if s.widened_range:
            d = s.wide_slope_m * (widened(self._left, self._right, s.edge_left, s.edge_right)
                                  - s.wide_intercept)
        error = -d
        self._integral += 0.01 * s.ki * error
        u2 = s.kp * error + self._integral
        stop = self._range < s.stop_range_m
        gate = 0.0 if stop else 1.0
        r = self.model.wheel_radius_m
        w_left = (s.v1_mps - s.half_track_m * u2) * gate / r
        w_right = (s.v1_mps + s.half_track_m * u2) * gate / r
        cmd = msg("sensor_msgs/msg/JointState", header=header(t_ns, self.frame),
                  name=["left_wheel_hinge", "right_wheel_hinge"], position=np.zeros(0),
                  velocity=np.array([w_left, w_right]), effort=np.zeros(0))
        state = msg("kartci_msgs/msg/LineControllerState", header=header(t_ns, self.frame),
                    distance_estimate_m=d, u2=u2, integral=self._integral, sonar_stop=stop)
        return [("wheel_cmd", cmd), ("controller/state", state)]


def widened(left: float, right: float, edge_left: float, edge_right: float) -> float:
    """Source document 001 Sec. 6.3 (Albert Costa's logic): past +0.008 m (left brighter than the
    right and than its own output there) y = left + right + c, past -0.008 m y = -(left + right) -
    c, else y = left - right. The source document writes c = 2 maxdiff for its cameras' scale; here
    c is the one value that joins the branches at +-0.008 m: maxdiff - (sum there) = -2 edge_right,
    so y is continuous and monotonic. Symmetric cameras: the right's output at -0.008 m is the
    left's at +0.008 m, so one threshold serves both sides."""
    c = -2.0 * edge_right
    if left > right and left > edge_left:
        return left + right + c
    if right > left and right > edge_left:
        return -(left + right) - c
    return left - right
