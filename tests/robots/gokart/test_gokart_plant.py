"""The kart plant's parts, each against its closed form: the simulated body weighs what the
parameters say, load transfer, the motors' torque-speed curve, the friction ellipse and the
longitudinal slip (kartci/robots/gokart/{inertia,tyres}.py)."""

from __future__ import annotations

import math
import random

import pytest

from kartci._bullet import pb
from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.robots.gokart.body import Gokart
from kartci.robots.gokart.params import GRAVITY_MPS2, GokartModel, axle_distance_m, cog_x_m
from kartci.robots.gokart.tyres import (
    Demand,
    FourTyres,
    air_drag_n,
    drive_demand,
    motor_force_n,
    normal_loads,
    peak_mps2,
    wheel_force,
    wheels,
)

MODELS = active_project().root / "models" / "gokart"
NOMINAL = GokartModel()


def _whole_body(model: GokartModel) -> tuple[float, float, float, float]:
    """Mass (kg), centre of mass x and z in base_link (m) and yaw inertia about it (kg m^2) of
    the loaded body, from PyBullet's dynamics info of every link."""
    c = pb.connect(pb.DIRECT)
    try:
        kart = Gokart(c, model, MODELS, (0.0, 0.0, 0.0), 0.002)
        base = kart.state().xyz
        links = []  # mass, CoM (x, y, z) relative to base_link, own izz
        for link in range(-1, pb.getNumJoints(kart.body, physicsClientId=c)):
            info = pb.getDynamicsInfo(kart.body, link, physicsClientId=c)
            com = (pb.getBasePositionAndOrientation(kart.body, physicsClientId=c)[0] if link < 0
                   else pb.getLinkState(kart.body, link, physicsClientId=c)[0])
            links.append((info[0], com[0] - base[0], com[1] - base[1], com[2] - base[2],
                          info[2][2]))
    finally:
        pb.disconnect(c)
    mass = sum(m for m, *_ in links)
    x = sum(m * lx for m, lx, *_ in links) / mass
    z = sum(m * lz for m, _, _, lz, _ in links) / mass
    izz = sum(i + m * ((lx - x) ** 2 + ly**2) for m, lx, ly, _, i in links)
    return mass, x, z, izz


@pytest.mark.parametrize("overrides", [{}, {"mass_kg": 340.0, "yaw_inertia_kgm2": 26.0,
                                            "cog_to_rear_axle_m": 0.5, "cog_height_m": 0.3}])
def test_the_simulated_body_has_the_parameters_mass_properties(overrides: dict[str, float],
                                                               ) -> None:
    model = NOMINAL.model_copy(update=overrides)
    mass, x, z, izz = _whole_body(model)
    assert mass == pytest.approx(model.mass_kg, abs=1e-6)
    assert x == pytest.approx(cog_x_m(model), abs=1e-6)
    assert z == pytest.approx(model.cog_height_m - model.rear_wheel_radius_m, abs=1e-6)
    assert izz == pytest.approx(model.yaw_inertia_kgm2, abs=1e-6)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("mass_kg", 5.0, "model.mass_kg: 5 kg is no more than the wheels and steer links alone "
     "(9 kg)"),
    ("yaw_inertia_kgm2", 1.0, "model.yaw_inertia_kgm2: 1 kg m^2 is no more than the wheels and "
     "steer links give alone (6.06 kg m^2)")])
def test_impossible_mass_properties_are_one_line(field: str, value: float, message: str) -> None:
    c = pb.connect(pb.DIRECT)
    try:
        with pytest.raises(SpecError) as err:
            Gokart(c, NOMINAL.model_copy(update={field: value}), MODELS, (0.0, 0.0, 0.0), 0.002)
    finally:
        pb.disconnect(c)
    assert str(err.value) == message


def test_load_transfer_moves_weight_by_its_lever() -> None:
    tyres = wheels(NOMINAL)
    m, h, length = NOMINAL.mass_kg, NOMINAL.cog_height_m, axle_distance_m(NOMINAL)
    static = normal_loads(NOMINAL, tyres, 0.0, 0.0)
    assert static == pytest.approx([w.static_kg for w in tyres])
    assert sum(static) == pytest.approx(m)
    # braking at 5 m/s^2: m a h / (g L) = 28.7 kg from the rear axle to the front
    braking = normal_loads(NOMINAL, tyres, -5.0, 0.0)
    moved = m * 5.0 * h / (GRAVITY_MPS2 * length)
    assert braking[2] + braking[3] - static[2] - static[3] == pytest.approx(moved)
    assert sum(braking) == pytest.approx(m)
    # a left turn at 6 m/s^2: each axle moves m_axle a h / (g track) to its right wheel, the
    # whole kart m a h / g in moment (the axles share it by their static loads)
    turning = normal_loads(NOMINAL, tyres, 0.0, 6.0)
    moment = sum((n - s) * -w.y_m * 2 for n, s, w in zip(turning, static, tyres, strict=True)) / 2
    assert moment == pytest.approx(m * 6.0 * h / GRAVITY_MPS2)
    assert turning[1] > static[1] and turning[0] < static[0]  # rr gains, rl loses
    # beyond tipping the inner wheels carry nothing, never less
    assert min(normal_loads(NOMINAL, tyres, 0.0, 60.0)) == 0.0


def test_motor_curve_is_torque_then_power() -> None:
    rear = wheels(NOMINAL)[0]
    corner = NOMINAL.motor_power_w * rear.radius_m / NOMINAL.wheel_torque_limit_nm  # 3.74 m/s
    assert corner == pytest.approx(3.743, abs=1e-3)
    assert motor_force_n(NOMINAL, rear, 0.0) == pytest.approx(95.0 / 0.127)
    assert motor_force_n(NOMINAL, rear, 0.9 * corner) == pytest.approx(95.0 / 0.127)
    assert motor_force_n(NOMINAL, rear, 10.0) == pytest.approx(280.0)  # 2.8 kW at 10 m/s
    assert motor_force_n(NOMINAL, rear, -10.0) == pytest.approx(280.0)  # and in reverse


def test_friction_ellipse_and_longitudinal_slip() -> None:
    model = NOMINAL.model_copy(update={"long_grip_ratio": 1.2, "rolling_resistance_coeff": 0.0})
    rear = wheels(model)[0]
    load, alpha = 100.0, 0.05  # kg, rad: the contact moves 0.05 rad off the wheel's heading
    v = (10.0 * math.cos(alpha), -10.0 * math.sin(alpha))
    pure = wheel_force(model, rear, load, Demand(0.0, 0.0), 0.0, v, 1.0)
    # D = mu g (1 + pDy2 dfz) on mu 1: 100 kg on a rear wheel of 87.65 kg static load
    d = GRAVITY_MPS2 * (1.0 - 0.1 * (load - rear.static_kg) / rear.static_kg)
    lateral = load * d * math.sin(1.1 * math.atan(5.2 * alpha))  # N D sin(C atan(B alpha))
    assert pure.fy_n == pytest.approx(lateral)
    # braking at 4 m/s^2 on 100 kg: F_x = 400 N; F_y scaled by the ellipse
    braked = wheel_force(model, rear, load, Demand(0.0, 4.0), 0.0, v, 1.0)
    f_x = -load * 4.0
    f_x_max = load * d * 1.2
    assert braked.fx_n == pytest.approx(f_x)
    assert braked.fy_n == pytest.approx(lateral * math.sqrt(1 - (f_x / f_x_max) ** 2))
    assert braked.slip == pytest.approx(f_x / (15.0 * load * GRAVITY_MPS2))  # -0.027
    assert braked.spin_mps == pytest.approx(v[0] * (1 + braked.slip))  # the wheel turns slower
    # beyond the ellipse's longitudinal axis the wheel locks: all of it along x, none sideways
    locked = wheel_force(model, rear, load, Demand(0.0, 20.0), 0.0, v, 1.0)
    assert (locked.fx_n, locked.fy_n, locked.slip, locked.spin_mps) == pytest.approx(
        (-f_x_max, 0.0, -1.0, 0.0))
    # a driven wheel beyond it spins: +1
    spinning = wheel_force(model, rear, 30.0, Demand(5.0, 0.0), 0.0, (1.0, 0.0), 1.0)
    light = GRAVITY_MPS2 * (1.0 - 0.1 * (30.0 - rear.static_kg) / rear.static_kg)
    assert (spinning.fx_n, spinning.slip, spinning.spin_mps) == pytest.approx(
        (30.0 * light * 1.2, 1.0, 2.0))


def test_the_loops_four_tyres_equal_the_per_wheel_model_to_the_last_bit() -> None:
    """FourTyres (the physics loop's flat form) against normal_loads, wheel_force and
    air_drag_n, over random states that reach every branch: load off a wheel, the slip-angle
    floor, the motors' power limit, the friction ellipse's edge, a lock, a spin, reverse, an
    emergency stop and a floor with no grip."""
    rng = random.Random(7)
    for model in (NOMINAL, NOMINAL.model_copy(update={"long_grip_ratio": 0.6,
                                                      "cog_height_m": 0.5})):
        off = (0.0123, -0.0021, 0.0456)
        four, tyres = FourTyres(model, off), wheels(model)
        for _ in range(3000):
            ax, ay = rng.uniform(-15.0, 15.0), rng.uniform(-40.0, 40.0)
            vx, vy, yaw_rate = (rng.uniform(-4.0, 20.0), rng.uniform(-3.0, 3.0),
                                rng.uniform(-3.0, 3.0))
            demand = drive_demand(model, rng.choice([0.0, rng.uniform(0.0, 8.0)]),
                                  rng.choice([0.0, rng.uniform(0.0, 30.0)]),
                                  rng.random() < 0.2, rng.random() < 0.05, vx)
            steer = (rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6))
            mu = [rng.choice([1.0, 0.0, rng.uniform(0.2, 1.3)]) for _ in range(4)]
            want, spins, fx_sum, fy_sum = [], [], 0.0, 0.0
            loads = normal_loads(model, tyres, ax, ay)
            for w, load, delta, m in zip(tyres, loads, (0.0, 0.0, *steer), mu, strict=True):
                dx, dy = w.x_m - off[0], w.y_m - off[1]
                f = wheel_force(model, w, load, demand, delta,
                                (vx - yaw_rate * dy, vy + yaw_rate * dx), m)
                want.append((f.fx_n, f.fy_n, load * peak_mps2(w.tyre, load, w.static_kg) * m))
                spins.append(f.spin_mps / w.radius_m)
                fx_sum, fy_sum = fx_sum + f.fx_n, fy_sum + f.fy_n
            drag = air_drag_n(model, vx)
            got = four.forces(demand, steer, vx, vy, yaw_rate, (ax, ay), mu)
            assert got == (want, spins, drag, ((fx_sum + drag) / model.mass_kg,
                                               fy_sum / model.mass_kg))
