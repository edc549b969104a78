"""Tyre forces of the simulated kart, computed per wheel and applied to the chassis at each
wheel's contact point every physics step (PyBullet's wheel contacts carry the weight only: they
have no friction).

Model (Pacejka, "Tire and Vehicle Dynamics"; Liniger, Domahidi, Morari 2015 and the ETH kart's
MPC for the lateral curve, REFERENCE.md), loads mass-normalised as there (kg, forces N = kg m/s^2):
- normal load: each axle's static share from the centre of mass, plus the longitudinal transfer
  m a_x h / L between the axles and the lateral transfer m_axle a_y h / track across each axle
  (h the CoM height, a_x and a_y the body's acceleration from the previous step's forces). The
  kart has no suspension, so how the roll moment splits between the axles is an assumption: in
  proportion to their static loads. A wheel never pulls the ground (N >= 0);
- peak force: at most the floor's mu times the load, falling with load (Pacejka's load
  sensitivity): D = mu g (pDy1 + pDy2 dfz) per kg of load, dfz = (N - N0) / N0 against the
  wheel's static load N0, pDy1 = 1 and pDy2 < 0 (`Tyre`, `peak_mps2`). An axle's two wheels
  together never exceed mu times their load: sum N_i (1 + pDy2 dfz_i) = sum N_i + pDy2
  sum (N_i - N0_i)^2 / N0_i whenever the loads sum to the static ones;
- lateral: the magic formula N D sin(C atan(B alpha)), alpha the slip angle of the contact's
  velocity in the wheel's frame;
- longitudinal: each rear motor's drive force on its own wheel (the command's m a_cmd / 2) within
  its torque-speed curve: the torque limit up to the corner speed, constant power above it;
  brake deceleration and rolling resistance on every wheel by its load;
- combined slip, friction ellipse: F_x is clipped to N D_x (D_x = `long_grip_ratio` D) and F_y
  scaled by sqrt(1 - (F_x / N D_x)^2), so driving or braking at the limit leaves no side grip;
- longitudinal slip, quasi-static (a wheel's spin settles within about 0.1 ms, far below a
  physics step): within the grip the slip ratio is F_x / (k N g), k the slip stiffness; a
  demand beyond it spins a driven wheel (+1) or locks a braked one (-1). It sets the wheel speeds
  that odometry reads;
- mu: the floor's or zone's friction coefficient times the kart's `tire_friction`;
- aerodynamic drag rho Cd A v |v| / 2 at the centre of mass.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from kartci.robots.gokart.params import (
    GRAVITY_MPS2,
    PDY1,
    GokartModel,
    Tyre,
    axle_distance_m,
    rolling_decel_mps2,
)

SLIP_SPEED_FLOOR_MPS = 1.0  # slip angles use max(|v_long|, this): finite at standstill
STOP_SPEED_MPS = 0.3  # brakes and rolling resistance fade out linearly below this speed
SPEED_LIMIT_BAND_MPS = 0.5  # the drive force fades out over this band below the top speed


def peak_mps2(tyre: Tyre, load_kg: float, static_kg: float) -> float:
    """Peak force per kg of load on a floor of friction 1, m/s^2: g (pDy1 + pDy2 dfz),
    dfz = (load - static) / static (Pacejka's load-dependent peak friction)."""
    return GRAVITY_MPS2 * (PDY1 + tyre.p_dy2 * ((load_kg - static_kg) / static_kg))


def pacejka(tyre: Tyre, alpha_rad: float, d_mps2: float) -> float:
    """Lateral force per kg of load, m/s^2, at slip angle `alpha_rad` (magic formula) with
    peak `d_mps2`."""
    return d_mps2 * math.sin(tyre.c * math.atan(tyre.b * alpha_rad))


@dataclass(frozen=True)
class Wheel:
    """One wheel: contact point in base_link (m), static load (kg), tyre, driven or not, and
    rolling radius (m)."""

    x_m: float
    y_m: float
    static_kg: float
    tyre: Tyre
    driven: bool
    radius_m: float


def wheels(model: GokartModel) -> list[Wheel]:
    """The four wheels (rl, rr, fl, fr) with static loads from the centre-of-mass position."""
    length, lr = axle_distance_m(model), model.cog_to_rear_axle_m
    rear_load, front_load = model.mass_kg * (length - lr) / length, model.mass_kg * lr / length
    out = []
    for i, (x, y) in enumerate(model.wheel_xy_m):
        front = i >= 2
        out.append(Wheel(x, y, (front_load if front else rear_load) / 2,
                         model.front_tyre if front else model.rear_tyre, not front,
                         model.front_wheel_radius_m if front else model.rear_wheel_radius_m))
    return out


def normal_loads(model: GokartModel, tyres: list[Wheel], ax_mps2: float, ay_mps2: float,
                 ) -> list[float]:
    """Each wheel's normal load, kg, at body acceleration (ax, ay), m/s^2: the static load plus
    longitudinal and lateral load transfer."""
    per_g = model.mass_kg * model.cog_height_m / GRAVITY_MPS2
    to_rear = per_g * ax_mps2 / axle_distance_m(model)  # kg from the front axle to the rear
    out = []
    for w in tyres:
        axle = max(0.0, 2 * w.static_kg + (to_rear if w.driven else -to_rear))  # driven: rear
        # the axle's share of the roll moment, to the outside of the turn (-y for a_y > 0)
        across = axle / model.mass_kg * per_g * ay_mps2 / (2 * abs(w.y_m))
        out.append(axle / 2 - math.copysign(min(abs(across), axle / 2), across * w.y_m))
    return out


class Demand(NamedTuple):
    """What the driver asks of the wheels: drive acceleration (m/s^2, signed: negative in
    reverse) and brake deceleration (m/s^2). A NamedTuple: one is made every physics step."""

    drive_mps2: float
    brake_mps2: float


@dataclass(frozen=True)
class TyreForce:
    """One wheel's force in the body frame (N), its longitudinal slip ratio, and its
    circumferential speed omega r (m/s: the road speed with the slip)."""

    fx_n: float
    fy_n: float
    slip: float
    spin_mps: float


def _fade(v: float) -> float:
    return max(-1.0, min(1.0, v / STOP_SPEED_MPS))


def motor_force_n(model: GokartModel, wheel: Wheel, v_long_mps: float) -> float:
    """The largest drive force of one rear motor at its wheel's speed, N: the torque limit up
    to the corner speed (power / torque x radius), constant power above it."""
    torque_cap = model.wheel_torque_limit_nm / wheel.radius_m
    return min(torque_cap, model.motor_power_w / max(abs(v_long_mps), 1e-9))


def wheel_force(model: GokartModel, wheel: Wheel, load_kg: float, demand: Demand,
                steer_rad: float, v_contact: tuple[float, float], mu_scale: float,
                ) -> TyreForce:
    """One wheel's force at normal load `load_kg`, its contact point moving at `v_contact`
    (body frame, m/s), on a floor of friction `mu_scale` (the floor's mu times the kart's
    `tire_friction`)."""
    c, s = math.cos(steer_rad), math.sin(steer_rad)
    v_long, v_lat = c * v_contact[0] + s * v_contact[1], -s * v_contact[0] + c * v_contact[1]
    alpha = -math.atan2(v_lat, max(abs(v_long), SLIP_SPEED_FLOOR_MPS))
    d = peak_mps2(wheel.tyre, load_kg, wheel.static_kg)
    f_lat = load_kg * mu_scale * pacejka(wheel.tyre, alpha, d)
    want = -load_kg * (demand.brake_mps2 + rolling_decel_mps2(model)) * _fade(v_long)
    if wheel.driven:  # each rear motor drives its own wheel, within its torque-speed curve
        cap = motor_force_n(model, wheel, v_long)
        want += max(-cap, min(cap, model.mass_kg * demand.drive_mps2 / 2))
    f_max = load_kg * d * model.long_grip_ratio * mu_scale
    f_long = max(-f_max, min(f_max, want))
    f_lat *= math.sqrt(max(0.0, 1.0 - (f_long / f_max) ** 2)) if f_max > 0 else 0.0
    stiffness = model.long_slip_stiffness * load_kg * GRAVITY_MPS2
    slip = f_long / stiffness if abs(want) <= f_max and stiffness > 0 else math.copysign(1.0, want)
    return TyreForce(c * f_long - s * f_lat, s * f_long + c * f_lat, slip,
                     v_long + slip * abs(v_long))


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
    """Aerodynamic drag along the body x axis, N: rho Cd A v |v| / 2."""
    return -0.5 * model.air_density_kgpm3 * model.drag_area_m2 * vx_mps * abs(vx_mps)


class FourTyres:
    """The four tyres' forces of one physics step in one flat loop, everything that stays the
    same between steps worked out once: the physics loop's fast path (its Python was half of
    a kart's step). The arithmetic is `normal_loads`, `wheel_force` and `air_drag_n` operation
    for operation, min and max written out as the builtins compare (`max(a, b)` is `b if b > a
    else a`), so the results are equal to the last bit
    (tests/robots/gokart/test_gokart_plant.py holds them so).

    Args:
        model: The kart's parameters.
        com_offset_m: The chassis' centre of mass in base_link (x, y, z), m: the forces'
            lever arms are measured from it.
    """

    def __init__(self, model: GokartModel, com_offset_m: tuple[float, float, float]) -> None:
        """Work out the per-wheel constants."""
        self.mass = model.mass_kg
        self.per_g = model.mass_kg * model.cog_height_m / GRAVITY_MPS2
        self.axle_m = axle_distance_m(model)
        self.rolling = rolling_decel_mps2(model)
        self.drag_k = -0.5 * model.air_density_kgpm3 * model.drag_area_m2
        self.grip_slip_power = (model.long_grip_ratio, model.long_slip_stiffness,
                                model.motor_power_w)
        ox, oy, _ = com_offset_m
        self.wheels = tuple(
            (2 * w.static_kg, w.driven, w.y_m, 2 * abs(w.y_m), w.x_m - ox, w.y_m - oy,
             w.static_kg, w.tyre.p_dy2, w.tyre.b, w.tyre.c, w.radius_m,
             model.wheel_torque_limit_nm / w.radius_m)
            for w in wheels(model))

    def forces(self, demand: Demand, steer_rad: tuple[float, float], vx_mps: float,
               vy_mps: float, yaw_rate_radps: float, accel_mps2: tuple[float, float],
               mu_scale: list[float]) -> tuple[list[tuple[float, float, float]], list[float],
                                               float, tuple[float, float]]:
        """Each wheel's (rl, rr, fl, fr) body-frame force and grip (N), its spin (rad/s), the
        air drag (N, along body x) and the body's acceleration from them all (m/s^2, x and y),
        for the front wheels at `steer_rad` and the centre of mass moving at (vx, vy) in the
        body frame and turning at `yaw_rate_radps`, after a step whose forces accelerated the
        body by `accel_mps2`."""
        mass, per_g = self.mass, self.per_g
        ratio, k_slip, power = self.grip_slip_power
        ax, ay = accel_mps2
        to_rear = per_g * ax / self.axle_m
        brake = demand.brake_mps2 + self.rolling
        drive = mass * demand.drive_mps2 / 2
        out: list[tuple[float, float, float]] = []
        spins: list[float] = []
        fx_sum = fy_sum = 0.0
        atan, atan2, sin, sqrt, copysign = math.atan, math.atan2, math.sin, math.sqrt, (
            math.copysign)
        left, right = steer_rad  # cos and sin of each wheel's steer angle (rear: exactly 1, 0)
        turns = ((1.0, 0.0), (1.0, 0.0), (math.cos(left), sin(left)),
                 (math.cos(right), sin(right)))
        for (two_static, driven, y, two_y, dx, dy, static, p_dy2, b, c, radius, torque_cap), (
                cs, sn), mu in (
                zip(self.wheels, turns, mu_scale, strict=True)):
            a = two_static + (to_rear if driven else -to_rear)
            axle = a if a > 0.0 else 0.0
            across = axle / mass * per_g * ay / two_y
            half, reach = axle / 2, abs(across)
            load = half - copysign(half if half < reach else reach, across * y)
            v0, v1 = vx_mps - yaw_rate_radps * dy, vy_mps + yaw_rate_radps * dx
            v_long, v_lat = cs * v0 + sn * v1, -sn * v0 + cs * v1
            speed = abs(v_long)
            alpha = -atan2(v_lat, SLIP_SPEED_FLOOR_MPS if speed < SLIP_SPEED_FLOOR_MPS
                           else speed)
            d = GRAVITY_MPS2 * (PDY1 + p_dy2 * ((load - static) / static))
            f_lat = load * mu * (d * sin(c * atan(b * alpha)))
            q = v_long / STOP_SPEED_MPS
            q = q if q < 1.0 else 1.0
            want = -load * brake * (q if q > -1.0 else -1.0)
            if driven:
                p = power / (1e-9 if speed < 1e-9 else speed)
                cap = p if p < torque_cap else torque_cap
                q = drive if drive < cap else cap
                want += q if q > -cap else -cap
            load_d = load * d
            f_max = load_d * ratio * mu
            q = want if want < f_max else f_max
            f_long = q if q > -f_max else -f_max
            if f_max > 0:
                q = 1.0 - (f_long / f_max) ** 2
                f_lat *= sqrt(q if q > 0.0 else 0.0)
            else:
                f_lat *= 0.0
            stiffness = k_slip * load * GRAVITY_MPS2
            slip = (f_long / stiffness if abs(want) <= f_max and stiffness > 0
                    else copysign(1.0, want))
            fx, fy = cs * f_long - sn * f_lat, sn * f_long + cs * f_lat
            out.append((fx, fy, load_d * mu))
            spins.append((v_long + slip * speed) / radius)
            fx_sum, fy_sum = fx_sum + fx, fy_sum + fy
        drag = self.drag_k * vx_mps * abs(vx_mps)
        return out, spins, drag, ((fx_sum + drag) / mass, fy_sum / mass)
