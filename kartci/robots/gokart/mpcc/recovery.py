"""Loss of control and stalls, seen from the measured state, and what the MPCC does about them.

A solver can report an optimal plan while the kart spins (the model's tyres hold where the
real ones slide) or while the kart stands still (a plan that parks is still a solution). The
watchdog judges the kart, not the solver: sideslip at the centre of mass, a yaw rate far from
the kinematic one, progress along the track. On a loss of control the kart brakes straight
(column centred) until it no longer slides, then the MPCC re-plans from scratch; a stall
re-plans from scratch too. Each such step is logged with its status, not as solved.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from kartci.robots.gokart.mpcc.params import MpccRecovery


class MpccStatus(StrEnum):
    """What the watchdog says of a control step (the solver's own status otherwise)."""

    LOSS_OF_CONTROL = "Loss_of_control"  # detected this step: braking straight from now
    RECOVERING = "Recovering"  # still braking straight: the kart slides
    STALLED = "Stalled"  # no progress for `stall_steps` steps: the plan is dropped


@dataclass(frozen=True)
class Measured:
    """One control step's measured state at the centre of mass: forward and lateral speed
    (m/s), yaw rate (rad/s), mean front-wheel angle (rad) and progress along the track (m)."""

    vx: float
    vy: float
    r: float
    delta: float
    s: float


class Watchdog:
    """Judges each control step from the measured state (see the module docstring)."""

    def __init__(self, spec: MpccRecovery, period_s: float, wheelbase_m: float) -> None:
        self.spec, self.period_s, self.wheelbase_m = spec, period_s, wheelbase_m
        self.recovering = False
        self._slow_steps = 0
        self._last_s: float | None = None

    def judge(self, m: Measured) -> MpccStatus | None:
        """This step's status, None when the kart is under control and moving on."""
        sp = self.spec
        speed = math.hypot(m.vx, m.vy)
        slip = math.degrees(abs(math.atan2(m.vy, m.vx))) if speed > sp.moving_mps else 0.0
        if self.recovering:
            self.recovering = slip >= sp.recovered_deg
            self._last_s = m.s
            return MpccStatus.RECOVERING if self.recovering else None
        yaw_excess = abs(m.r - m.vx * math.tan(m.delta) / self.wheelbase_m)
        if speed > sp.moving_mps and (slip > sp.sideslip_deg
                                      or yaw_excess > sp.yaw_rate_excess_radps):
            self.recovering = True
            self._last_s = m.s
            return MpccStatus.LOSS_OF_CONTROL
        stalled = self._stalled(m.s)
        return MpccStatus.STALLED if stalled else None

    def _stalled(self, s: float) -> bool:
        last, self._last_s = self._last_s, s
        if last is None:
            return False
        slow = (s - last) / self.period_s < self.spec.stall_mps
        self._slow_steps = self._slow_steps + 1 if slow else 0
        if self._slow_steps >= self.spec.stall_steps:
            self._slow_steps = 0
            return True
        return False
