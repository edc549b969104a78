"""The MPCC's watchdog on synthetic state sequences, and the ground it plans on: the power limit
and the floor's friction in its model, against closed forms."""

from __future__ import annotations

import math
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from kartci.robots.gokart.mpcc.model import ACC, DELTA, NU, NX, VX, VY, R, SingleTrack, continuous
from kartci.robots.gokart.mpcc.params import MpccRecovery, MpccVehicle
from kartci.robots.gokart.mpcc.recovery import Measured, MpccStatus, Watchdog
from kartci.robots.gokart.mpcc.reference import FrictionMap, Obstacle, TrackWidths, stage_params
from kartci.robots.gokart.params import GokartModel, axle_distance_m
from kartci.worlds.hall import HallWorld
from kartci.worlds.track import FloorZone, Track, track_from_rows

PERIOD_S = 0.05
KART = GokartModel()


def _watchdog() -> Watchdog:
    return Watchdog(MpccRecovery(), PERIOD_S, axle_distance_m(KART))


def _sliding(slip_deg: float, s: float, speed: float = 6.0) -> Measured:
    a = math.radians(slip_deg)
    return Measured(speed * math.cos(a), speed * math.sin(a), 0.0, 0.0, s)


def test_a_slide_is_a_loss_of_control_then_recovery_until_it_grips_again() -> None:
    dog = _watchdog()
    slips = [2.0, 8.0, 25.0, 30.0, 12.0, 6.0, 4.0, 3.0]
    statuses = [dog.judge(_sliding(a, 0.3 * i)) for i, a in enumerate(slips)]
    assert statuses == [None, None, MpccStatus.LOSS_OF_CONTROL, MpccStatus.RECOVERING,
                        MpccStatus.RECOVERING, MpccStatus.RECOVERING, None, None]


def test_slow_sideslip_is_not_judged_and_a_yaw_rate_beyond_the_model_is() -> None:
    dog = _watchdog()
    assert dog.judge(_sliding(60.0, 0.0, speed=1.0)) is None  # parking speed: noise
    dog = _watchdog()
    # straight wheels, 6 m/s, 1.5 rad/s: the kinematic yaw rate is 0
    assert dog.judge(Measured(6.0, 0.0, 1.5, 0.0, 0.0)) is MpccStatus.LOSS_OF_CONTROL
    dog = _watchdog()
    turning = 6.0 * math.tan(0.15) / axle_distance_m(KART)
    assert dog.judge(Measured(6.0, 0.0, turning + 0.5, 0.15, 0.0)) is None


def test_no_progress_for_stall_steps_is_stalled_not_solved() -> None:
    dog = _watchdog()
    steps = MpccRecovery().stall_steps
    statuses = [dog.judge(Measured(0.0, 0.0, 0.0, 0.0, 10.0 + 1e-4 * i))
                for i in range(steps + 1)]
    assert statuses[:steps] == [None] * steps
    assert statuses[steps] is MpccStatus.STALLED
    moving = _watchdog()
    assert {moving.judge(Measured(2.0, 0.0, 0.0, 0.0, 0.1 * i)) for i in range(2 * steps)} == {
        None}


def test_the_friction_map_is_the_worlds_floor_and_zones() -> None:
    hall = HallWorld(track="winti/track.csv", floor_friction=0.9,
                      zones=(FloorZone(name="coated", min_m=(24.0, 0.0), max_m=(32.0, 20.0),
                                       friction=0.3),))
    points = np.array([[10.0, 5.0], [25.0, 5.0]])
    # the grip is the tyres' friction coefficient there: the floor's mu times tire_friction
    assert FrictionMap.of(hall, 1.0).grip(points).tolist() == pytest.approx([0.9, 0.3])
    assert FrictionMap.of(hall, 0.5).grip(points).tolist() == pytest.approx([0.45, 0.15])
    assert FrictionMap.of(None, 1.0).grip(np.zeros((1, 2))).tolist() == [0.9]  # concrete


def _derivative(vx: float, vy: float, r: float, delta: float, acc: float,
                grip: float, model: GokartModel = KART) -> np.ndarray:
    x = np.zeros(NX)
    x[VX], x[VY], x[R], x[DELTA], x[ACC] = vx, vy, r, delta, acc
    out = continuous(ca.SX(ca.DM(x)), ca.SX.zeros(NU), SingleTrack.of(model), MpccVehicle(), grip)
    return np.asarray(ca.evalf(out)).ravel()


@pytest.mark.parametrize("grip", [0.3 / 0.9, 0.5])
def test_the_floors_grip_scales_the_tyre_forces_of_the_model(grip: float) -> None:
    """Coasting (no longitudinal force) at 10 m/s, where the model is the dynamic one: the lateral
    tyre forces, dvy/dt + vx r and the yaw acceleration, are D sin(C atan(B alpha)) and scale
    with D (to the smooth-min's 0.05 m/s^2 of brake force in the friction circle)."""
    vx, vy, r, delta = 10.0, 0.2, 0.3, 0.05
    full, scaled = (_derivative(vx, vy, r, delta, 0.0, g) for g in (1.0, grip))
    assert scaled[VY] + vx * r == pytest.approx(grip * (full[VY] + vx * r), rel=1e-3)
    assert scaled[R] == pytest.approx(grip * full[R], rel=1e-3)


@pytest.mark.parametrize("mass_kg", [283.4, 340.08])
def test_the_models_drive_is_power_limited_above_the_corner_speed(mass_kg: float) -> None:
    """Full throttle at 8 m/s, straight: 2 x 2.8 kW / (m v) less rolling resistance and drag."""
    model = KART.model_copy(update={"mass_kg": mass_kg})
    m, v = SingleTrack.of(model), 8.0
    expected = (2 * model.motor_power_w / mass_kg / math.sqrt(v * v + 1.0)
                - m.rolling_decel_mps2 * math.tanh(v / 0.3) - m.air_drag_per_m * v * v)
    assert _derivative(v, 0.0, 0.0, 0.0, 5.0, 1.0, model)[VX] == pytest.approx(expected,
                                                                              rel=1e-3)


def _circle_track() -> Track:
    a = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
    rows = np.column_stack([30 * np.cos(a), 30 * np.sin(a), np.full(64, 2.0), np.full(64, 2.0)])
    return track_from_rows(rows, Path("circle.csv"))


@pytest.mark.parametrize(("follow_gap_m", "hi_m"), [(3.0, 0.81 + 0.4), (0.0, 0.81)])
def test_a_kart_is_passed_inside_the_edge_margin_and_a_box_is_not(follow_gap_m: float,
                                                                   hi_m: float) -> None:
    """4 m track, padding 1.19 m (outline 0.69 + 0.5): the corridor is +-0.81 m. Something 0.69
    m wide at -0.8 m with a 0.9 m margin needs the centre line at >= 0.79 m: beside a kart the
    left bound gives 0.4 m of the edge margin (margin 0.5 -> 0.1 m), beside a box it does not."""
    track = _circle_track()
    ob = Obstacle(10.0, -0.8, 0.69, 0.0, follow_gap_m)
    rows = stage_params(TrackWidths.of(track), np.array([10.0]), 0.075, 1.19, [ob], 0.9, 2.0,
                        squeeze_m=0.4)
    lo, hi, s_max = rows[0, 5:8]
    assert (lo, hi, s_max) == pytest.approx((-0.8 + 0.69 + 0.9, hi_m, 1e6))
