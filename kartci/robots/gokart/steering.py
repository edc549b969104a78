"""The kart's commands and its steering map (column angle to front-wheel angles, and back):
public, for the simulator, kartci's controllers and a team's own kart controller alike."""

from __future__ import annotations

import math
from dataclasses import dataclass

from kartci.robots.gokart.params import GokartModel, axle_distance_m


@dataclass(frozen=True)
class KartInput:
    """A go-kart command in the source document's simulation format (Sec. 5.2)."""

    steering_rad: float = 0.0  # steering-column (steering-wheel) angle, left +
    accel_mps2: float = 0.0  # motor: acceleration
    brake_mps2: float = 0.0  # brake: deceleration
    reverse: bool = False
    estop: bool = False


STEERING_RATIO = 0.36  # wheel angle per steering-column angle: the linear term of Eq. 3.4


def wheel_angles(model: GokartModel, beta_c: float) -> tuple[float, float]:
    """Left and right front-wheel (steer-joint) angles, rad, for a steering-column angle, rad.

    The source document's Eq. 3.1/3.2 and 3.4/3.5 turn the right wheel more for a positive column
    angle: Ackermann-consistent (inner wheel more) when positive means a right turn. Here positive
    is a left turn (about +z), so the map is mirrored left-right: the source document's right-wheel
    equations give the left wheel, which is then the inner wheel of a left turn. (Taking the
    equations with their sides as written would be anti-Ackermann: with slip-angle tyres the
    front wheels would fight each other in tight turns.) The measured map is not symmetric: at
    +1.73 rad the left wheel turns 0.575 rad and the right 0.303 rad.
    """
    if model.steering == "measured":  # Eq. 3.4 / 3.5 (sides mirrored), fitted to Table 3.3
        left = -0.0355 * beta_c**3 + 0.0455 * beta_c**2 + 0.36 * beta_c
        right = -0.0355 * beta_c**3 - 0.0455 * beta_c**2 + 0.36 * beta_c
        return left, right
    # Eq. 3.2 / 3.1 (sides mirrored), the virtual centre wheel at STEERING_RATIO x the column angle
    t = math.tan(STEERING_RATIO * beta_c)
    lw, w = model.wheelbase_m, model.track_m
    return math.atan2(lw * t, lw - 0.5 * w * t), math.atan2(lw * t, lw + 0.5 * w * t)


def column_for_wheel_angle(model: GokartModel, delta: float) -> float:
    """Steering-column angle whose mean front-wheel angle is `delta` (bisection; monotonic)."""
    lo, hi = model.steering_limit_rad
    for _ in range(40):
        mid = (lo + hi) / 2
        if sum(wheel_angles(model, mid)) / 2 < delta:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def speed_to_pedals(v_cmd: float, v: float, gain_per_s: float) -> tuple[float, float, bool]:
    """Throttle and brake (m/s^2) and reverse from a proportional loop on speed (m/s)."""
    reverse = v_cmd < 0
    a = gain_per_s * (abs(v_cmd) - abs(v))
    return max(a, 0.0), max(-a, 0.0), reverse


def steer_for_turn_rate(model: GokartModel, v_mps: float, yaw_rate_radps: float) -> float:
    """Mean front-wheel angle (rad) of the bicycle relation delta = atan(L w / v); below
    0.5 m/s the speed is held at 0.5 m/s so a turn at standstill stays bounded."""
    v_eff = v_mps if abs(v_mps) >= 0.5 else math.copysign(0.5, v_mps)
    return math.atan(axle_distance_m(model) * yaw_rate_radps / v_eff)
