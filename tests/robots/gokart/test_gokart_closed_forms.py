"""The simulated kart against closed forms of its own parameters (issue 26, item 6): coast-down,
0-10 m/s under the motors' torque-speed curve (and with 20 % more mass), a steady circle's
understeer gradient and a step steer's yaw rate from the linear single-track model. Each
compares the PyBullet plant with the analytic value within a stated tolerance.

Notation: m mass (kg), F_r = c_rr m g rolling resistance (N), k = rho Cd A / 2 (kg/m),
L axle distance, a and b the CoM to the front and rear axle (m)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm
from test_gokart_dynamics import DT, FLOOR_MU, Driver, drive

from kartci.robots.gokart import KartInput
from kartci.robots.gokart.params import GRAVITY_MPS2, GokartModel, axle_distance_m
from kartci.robots.gokart.steering import wheel_angles


def _resistances(model: GokartModel) -> tuple[float, float]:
    """F_r (N) and k (kg/m)."""
    return (model.rolling_resistance_coeff * model.mass_kg * GRAVITY_MPS2,
            0.5 * model.air_density_kgpm3 * model.drag_area_m2)


def coast_speed(model: GokartModel, v0_mps: float, t_s: np.ndarray) -> np.ndarray:
    """m dv/dt = -(F_r + k v^2): v(t) = sqrt(F_r/k) tan(atan(v0 sqrt(k/F_r)) - t sqrt(F_r k)/m)."""
    f_r, k = _resistances(model)
    scale = math.sqrt(f_r / k)
    out: np.ndarray = scale * np.tan(math.atan(v0_mps / scale)
                                     - t_s * math.sqrt(f_r * k) / model.mass_kg)
    return out


def time_to_speed(model: GokartModel, accel_mps2: float, v_mps: float) -> float:
    """Time from standstill to `v_mps` at a constant command `accel_mps2`, s. The drive force is
    F_1 = min(m a, 2 T / r) (the command, or both motors' torque limit) up to v_1 = 2 P / F_1,
    then 2 P / v (both motors at rated power). Phase 1, m dv/dt = A - k v^2 with A = F_1 - F_r:
    t = m atanh(v sqrt(k/A)) / sqrt(A k). Phase 2, m v dv / (2P - F_r v - k v^3): partial
    fractions over the roots r_i of k v^3 + F_r v - 2P, t = m sum_i c_i ln(v - r_i) with
    c_i = -r_i / (k prod_{j != i} (r_i - r_j))."""
    m, power = model.mass_kg, 2 * model.motor_power_w
    f_r, k = _resistances(model)
    f_1 = min(m * accel_mps2, 2 * model.wheel_torque_limit_nm / model.rear_wheel_radius_m)
    v_1 = min(power / f_1, v_mps)
    a = f_1 - f_r
    t = m * math.atanh(v_1 * math.sqrt(k / a)) / math.sqrt(a * k)
    if v_mps <= v_1:
        return t
    roots = np.roots([k, 0.0, f_r, -power])
    total = 0j
    for i, r in enumerate(roots):
        c = -r / (k * np.prod([r - q for j, q in enumerate(roots) if j != i]))
        total += c * (np.log(v_mps - r) - np.log(v_1 - r))
    return t + m * float(total.real)


def understeer_gradient(model: GokartModel, mu: float = FLOOR_MU) -> float:
    """K, rad per m/s^2, of delta = L / R + K a_y: each axle's slip angle is its lateral force
    over its cornering stiffness, and with tyres per kg of load (stiffness = axle load x B C D,
    D = mu g at the static load) the axle loads cancel: K = 1 / (B C D)_front -
    1 / (B C D)_rear. Negative: oversteer."""
    f, r, d = model.front_tyre, model.rear_tyre, mu * GRAVITY_MPS2
    return 1.0 / (f.b * f.c * d) - 1.0 / (r.b * r.c * d)


def bicycle_step(model: GokartModel, v_mps: float, delta_rad: float, t_s: np.ndarray,
                 ) -> np.ndarray:
    """Yaw rate (rad/s) of the linear single-track model after a steering step at `v_mps`:
    x = [v_y, r], x' = A x + B delta, x(t) = A^-1 (e^{A t} - I) B delta."""
    length, b = axle_distance_m(model), model.cog_to_rear_axle_m
    a, m, iz = length - b, model.mass_kg, model.yaw_inertia_kgm2
    d = FLOOR_MU * GRAVITY_MPS2  # the peak per kg at the static loads
    c_f = m * b / length * model.front_tyre.b * model.front_tyre.c * d
    c_r = m * a / length * model.rear_tyre.b * model.rear_tyre.c * d
    mat = np.array([[-(c_f + c_r) / (m * v_mps), -v_mps - (a * c_f - b * c_r) / (m * v_mps)],
                    [-(a * c_f - b * c_r) / (iz * v_mps), -(a * a * c_f + b * b * c_r)
                     / (iz * v_mps)]])
    vec = np.array([c_f / m, a * c_f / iz]) * delta_rad
    inv = np.linalg.inv(mat)
    return np.array([(inv @ (expm(mat * t) - np.eye(2)) @ vec)[1] for t in t_s])


def _hold(v_mps: float, column_rad: float = 0.0, gain_per_s: float = 3.0) -> Driver:
    """Hold the column and the speed (a proportional loop on the pedals)."""

    def driver(k: int, state: tuple[float, float]) -> KartInput:
        a = gain_per_s * (v_mps - state[0])
        return KartInput(steering_rad=column_rad, accel_mps2=max(a, 0.0),
                         brake_mps2=max(-a, 0.0))
    return driver


def test_coast_down_follows_rolling_resistance_and_drag() -> None:
    rows, model = drive(lambda k, _: KartInput(), 8.0, 10.0)
    moving = rows[:, 3] > 1.0  # the rolling resistance fades out below 0.3 m/s
    expected = coast_speed(model, 10.0, rows[moving, 0])
    # 8 s of coasting lose 1.9 m/s; within 0.5 % of the closed form at every step (measured:
    # 0.33 %, while the body settles on its wheels)
    assert rows[-1, 3] == pytest.approx(expected[-1], rel=0.005)
    error = np.abs(rows[moving, 3] / expected - 1.0)
    assert error.max() < 0.005
    assert error[rows[moving, 0] > 0.1].max() < 1e-4  # settled: 0.001 %
    assert rows[-1, 3] < 8.6


def _time_to(rows: np.ndarray, v_mps: float) -> float:
    i = int(np.argmax(rows[:, 3] >= v_mps))
    assert i > 0, f"the kart never reached {v_mps} m/s"
    # linear interpolation between the two physics steps around the crossing
    v0, v1 = rows[i - 1, 3], rows[i, 3]
    return float(rows[i - 1, 0] + DT * (v_mps - v0) / (v1 - v0))


def zero_to_ten(mass_kg: float | None = None) -> tuple[float, GokartModel]:
    """The plant's 0-10 m/s time at full throttle (5 m/s^2), s; the speed governor raised to
    12 m/s so that it does not fade the drive before 10 m/s."""
    extra = () if mass_kg is None else (f"mass_kg={mass_kg}",)
    rows, model = drive(lambda k, _: KartInput(accel_mps2=5.0), 4.5, 0.0,
                        model_set=("max_speed_mps=12", *extra))
    return _time_to(rows, 10.0), model


def test_zero_to_ten_under_the_power_limit() -> None:
    got, model = zero_to_ten()
    # 283.4 kg: 1417 N of command up to 3.95 m/s, then 2 x 2.8 kW: 3.14 s (5 m/s^2 throughout
    # would take 2.0 s); within 1 % (measured: 0.06 %)
    assert got == pytest.approx(time_to_speed(model, 5.0, 10.0), rel=0.01)
    assert got > 3.0


def test_twenty_percent_more_mass_is_slower_by_the_closed_form_ratio() -> None:
    nominal, model = zero_to_ten()
    heavy, heavy_model = zero_to_ten(model.mass_kg * 1.2)
    assert heavy_model.mass_kg == pytest.approx(1.2 * model.mass_kg)
    # 340 kg: the torque limit (1496 N) binds below the corner speed 3.74 m/s, and the power
    # phase takes 20 % longer: the closed forms' ratio 1.196, within 1 % (measured: 0.002 %)
    ratio = time_to_speed(heavy_model, 5.0, 10.0) / time_to_speed(model, 5.0, 10.0)
    assert heavy / nominal == pytest.approx(ratio, rel=0.01)
    assert ratio > 1.15


@pytest.mark.parametrize(("column_rad", "v_mps"), [(0.2, 5.0), (0.1, 7.0)])
def test_steady_circle_understeer_gradient(column_rad: float, v_mps: float) -> None:
    rows, model = drive(_hold(v_mps, column_rad), 6.0, v_mps)
    last = rows[-250:]  # the last 0.5 s
    speed = float(np.mean(np.hypot(last[:, 3], last[:, 6])))
    yaw_rate, delta = float(np.mean(last[:, 4])), float(np.mean(last[:, 5]))
    ay, radius = speed * yaw_rate, speed / yaw_rate
    k = understeer_gradient(model)  # -0.0072 rad per m/s^2 at mu 0.9: the ETH tyres oversteer
    assert 1.0 < ay < 3.0  # the linear range of the tyres
    # delta - L / R is K a_y (-0.01 rad here): within 10 % (measured: 3 % and 2 % less
    # oversteer, load transfer with the steering geometry's toe)
    assert (delta - axle_distance_m(model) / radius) == pytest.approx(k * ay, rel=0.10)


def test_step_steer_yaw_rate_against_the_linear_single_track_model() -> None:
    # 9 m/s, K v^2 = -0.58 m against L = 1.21 m: the response leans on the oversteer; a_y 2 m/s^2
    rows, model = drive(_hold(9.0, 0.05), 3.0, 9.0)
    t, yaw = rows[:, 0], rows[:, 4]
    speed = float(np.mean(np.hypot(rows[-250:, 3], rows[-250:, 6])))  # the loop's, 8.9 m/s
    delta = float(np.mean(rows[-250:, 5]))
    linear = bicycle_step(model, speed, delta, t)
    steady = speed * delta / (axle_distance_m(model) + understeer_gradient(model) * speed**2)
    assert linear[-1] == pytest.approx(steady, rel=1e-3)  # the closed form's own steady state
    # the plant's steady yaw rate within 2.5 % of the linear model's (measured: 1.3 % below)
    assert float(np.mean(yaw[-250:])) == pytest.approx(steady, rel=0.025)
    # the time to 90 % within 0.04 s of the linear model's 0.36 s (the column's slew and the
    # steer joints' lag are in the plant only)
    t90 = [float(t[np.argmax(y >= 0.9 * steady)]) for y in (yaw, linear)]
    assert t90[0] == pytest.approx(t90[1], abs=0.04)
    # never turning the wrong way, and an overshoot no larger than the ideal step's plus 2
    # points: the linear model's is 0 (the oversteering kart's yaw mode is overdamped below
    # its critical speed sqrt(L / -K) = 12.9 m/s at mu 0.9), and a slewed step, a moving
    # average of the step response, cannot peak higher
    assert yaw.min() > -0.01 * steady
    assert yaw.max() / steady - 1.0 <= linear.max() / steady - 1.0 + 0.02


def test_a_steering_offset_turns_a_kart_held_straight_as_that_column_angle_does() -> None:
    """`steering_offset_rad` (issue 42's miscalibrated centre): commanded straight, the column
    settles at the offset, and the kart circles as one commanded to that angle does (0.086
    rad/s at 5 m/s here)."""
    offset, v = 0.05, 5.0
    rows, model = drive(_hold(v), 4.0, v, model_set=(f"steering_offset_rad={offset}",))
    commanded, _ = drive(_hold(v, offset), 4.0, v)
    straight, _ = drive(_hold(v), 4.0, v)
    wheel = sum(wheel_angles(model, offset)) / 2
    assert float(np.mean(rows[-250:, 5])) == pytest.approx(wheel, abs=1e-9)
    yaw_rate = float(np.mean(rows[-250:, 4]))
    assert yaw_rate == pytest.approx(float(np.mean(commanded[-250:, 4])), rel=1e-6)
    # the single-track model's steady yaw rate for that wheel angle, delta = L r / v + K v r,
    # within the 10 % of the understeer test above
    closed = wheel / (axle_distance_m(model) / v + understeer_gradient(model) * v)
    assert yaw_rate == pytest.approx(closed, rel=0.10)
    assert abs(float(np.mean(straight[-250:, 4]))) < 1e-3


def test_a_command_delay_shifts_the_response_by_the_dead_time() -> None:
    """`command_delay_s` (a congested bus): a throttle step from rest takes effect 0.05 s
    (25 physics steps) later; the speed then follows the undelayed run's, shifted."""
    def step(k: int, state: tuple[float, float]) -> KartInput:
        return KartInput(0.0, 3.0, 0.0)

    late, _ = drive(step, 1.5, 0.0, model_set=("command_delay_s=0.05",))
    now, _ = drive(step, 1.5, 0.0)
    shift = 25
    assert abs(late[shift - 1, 3]) < 0.01 < now[shift - 1, 3]
    # the first 25 steps settle the kart on its wheels either way: the shifted curves agree
    # to within 1 % once moving
    assert late[shift + 500:, 3] == pytest.approx(now[500:-shift, 3], rel=0.01)
