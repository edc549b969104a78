"""Tyre forces of the simulated kart, computed per wheel and applied to the chassis each physics
step (PyBullet's contacts only carry the kart's weight and collisions: the wheels have no
contact friction).

Model (Liniger, Domahidi, Morari 2015, "Optimization-based autonomous racing of 1:43 scale RC
cars", and the ETH kart's MPC, REFERENCE.md; Pacejka, "Tire and Vehicle Dynamics"):
- lateral: the magic formula F_y = N D sin(C atan(B alpha)), N the wheel's static load in kg
  (mass-normalised: D in m/s^2), alpha the slip angle from the wheel's velocity in its own frame;
- longitudinal: the drive force m a_cmd on the rear wheels (two motors, each within its torque
  limit), brake deceleration, rolling resistance and drivetrain drag on every wheel by load
  share, aerodynamic drag at the centre of mass;
- a friction circle of radius N D per wheel: the longitudinal force is clipped to it and the
  lateral force scaled by sqrt(1 - (F_x / N D)^2), so braking or driving at the limit costs grip;
- the floor's friction mu scales D by mu / `tyre_reference_friction`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from kartci.robots.gokart.params import GokartModel, Tyre, axle_distance_m, cog_x_m

SLIP_SPEED_FLOOR_MPS = 1.0  # slip angles use hypot(v_long, this): finite at standstill
STOP_SPEED_MPS = 0.3  # brakes and rolling resistance fade out linearly below this speed
SPEED_LIMIT_BAND_MPS = 0.5  # the drive force fades out over this band below the top speed


def pacejka(tyre: Tyre, alpha_rad: float) -> float:
    """Lateral force per kg of load, m/s^2, at slip angle `alpha_rad` (magic formula)."""
    return tyre.d_mps2 * math.sin(tyre.c * math.atan(tyre.b * alpha_rad))


@dataclass(frozen=True)
class Wheel:
    """One wheel: contact point relative to the centre of mass (body frame, m), static load (kg)
    and tyre."""

    dx_m: float
    dy_m: float
    load_kg: float
    tyre: Tyre
    driven: bool


def wheels(model: GokartModel) -> list[Wheel]:
    """The four wheels (rl, rr, fl, fr) with static loads from the centre-of-mass position."""
    length, lr, cx = axle_distance_m(model), model.cog_to_rear_axle_m, cog_x_m(model)
    rear_load, front_load = model.mass_kg * (length - lr) / length, model.mass_kg * lr / length
    out = []
    for i, (x, y) in enumerate(model.wheel_xy_m):
        front = i >= 2
        out.append(Wheel(x - cx, y, (front_load if front else rear_load) / 2,
                         model.front_tyre if front else model.rear_tyre, not front))
    return out


@dataclass(frozen=True)
class Demand:
    """What the driver asks of the wheels: drive acceleration (m/s^2, signed: negative in
    reverse) and brake deceleration (m/s^2)."""

    drive_mps2: float
    brake_mps2: float


def _fade(v: float) -> float:
    return max(-1.0, min(1.0, v / STOP_SPEED_MPS))


def wheel_force(model: GokartModel, wheel: Wheel, demand: Demand, steer_rad: float,
                v_body: tuple[float, float], yaw_rate: float, mu_scale: float,
                ) -> tuple[float, float]:
    """Body-frame (x, y) force, N, of one wheel at body velocity `v_body` (m/s, at the centre
    of mass) and `yaw_rate` (rad/s)."""
    vx = v_body[0] - yaw_rate * wheel.dy_m
    vy = v_body[1] + yaw_rate * wheel.dx_m
    c, s = math.cos(steer_rad), math.sin(steer_rad)
    v_long, v_lat = c * vx + s * vy, -s * vx + c * vy
    alpha = -math.atan2(v_lat, math.hypot(v_long, SLIP_SPEED_FLOOR_MPS))
    n = wheel.load_kg
    f_max = n * wheel.tyre.d_mps2 * mu_scale
    f_lat = n * mu_scale * pacejka(wheel.tyre, alpha)
    f_long = -n * (demand.brake_mps2 + model.rolling_decel_mps2) * _fade(v_long)
    if wheel.driven:  # two rear motors share the drive force, each within its torque limit
        torque_cap = model.wheel_torque_limit_nm / model.rear_wheel_radius_m
        f_long += max(-torque_cap, min(torque_cap, model.mass_kg * demand.drive_mps2 / 2))
    f_long = max(-f_max, min(f_max, f_long))
    f_lat *= math.sqrt(max(0.0, 1.0 - (f_long / f_max) ** 2)) if f_max > 0 else 0.0
    return c * f_long - s * f_lat, s * f_long + c * f_lat


def drive_demand(model: GokartModel, accel_mps2: float, brake_mps2: float, reverse: bool,
                 estop: bool, v_long_mps: float) -> Demand:
    """The motors' acceleration, faded out near the top speed (forward or reverse), and the
    brake; an emergency stop brakes at the largest deceleration."""
    if estop:
        return Demand(0.0, model.max_brake_mps2)
    limit = model.reverse_speed_mps if reverse else model.max_speed_mps
    v = -v_long_mps if reverse else v_long_mps
    fade = max(0.0, min(1.0, (limit - v) / SPEED_LIMIT_BAND_MPS))
    return Demand((-1.0 if reverse else 1.0) * accel_mps2 * fade, brake_mps2)


def air_drag_n(model: GokartModel, vx_mps: float) -> float:
    """Aerodynamic drag along the body x axis, N."""
    return -model.mass_kg * model.air_drag_per_m * vx_mps * abs(vx_mps)
