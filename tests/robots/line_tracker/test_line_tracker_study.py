"""The source document's study (Sec. 7.1-7.3) in kartci: the trends of its straight-line figures,
what its circle result depends on, and the Gazebo effects modelled to find out
(docs/line_tracker_study.md). Each test runs the fewest, shortest runs that show its point; the full
grids are their own suite (`kartci run line_straight_grid line_circle_grid line_circle_edge_fast
line_circle_edge_slow`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from kartci.metrics import compute
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import simulate

CTRL = "agents.lt0.controller"
MODEL = "agents.lt0.model"
SEED_GAZEBO = [f"{MODEL}.wheel_drive=set_velocity", f"{MODEL}.wheel_mass_kg=1",
               f"{MODEL}.wheel_inertia_kgm2=1", f"{MODEL}.caster_friction=1"]


def _run(tmp_path: Path, name: str, *sets: str) -> dict[str, float]:
    spec = load_scenario(name, list(sets), project=active_project())
    log = tmp_path / f"{len(list(tmp_path.iterdir()))}.mcap"
    simulate(spec, log)
    return {k: m.value for k, m in compute(log)[1].items()}


def _straight(tmp_path: Path, kp: float, ts: float, v1: float) -> dict[str, float]:
    """A release 5 mm off the straight line, 8 s (settles well within it at Kp >= 50)."""
    return _run(tmp_path, "line_straight_grid", "duration_s=8", f"{CTRL}.kp={kp}",
                f"{CTRL}.period_s={ts}", f"{CTRL}.v1_mps={v1}")


def test_fig_7_1_3_faster_driving_overshoots_more(tmp_path: Path) -> None:
    """Kp 100, ts 0.06 s: the release is second order, its overshoot grows with v1 (the loop's
    damping falls as 1/sqrt(v1)) while it settles and keeps the line."""
    runs = [_straight(tmp_path, 100, 0.06, v) for v in (0.01, 0.1, 0.5)]
    over = [r["overshoot_ratio"] for r in runs]
    assert over[0] < over[1] < over[2]
    assert over[1] > 0.1 and over[2] > 0.3  # underdamped: second order, not first
    for r in runs:
        assert r["line_lost"] == 0 and r["settle_time_s"] < 2.0


def test_fig_7_1_4_a_higher_gain_answers_sooner_and_overshoots_less(tmp_path: Path) -> None:
    """ts 0.06 s, v1 0.1 m/s: raising Kp 50 -> 100 -> 150 brings the peak sooner, the overshoot
    down and settling sooner (damping grows as sqrt(Kp) with the sensor ahead of the axle)."""
    runs = [_straight(tmp_path, kp, 0.06, 0.1) for kp in (50, 100, 150)]
    peak = [r["peak_time_s"] for r in runs]
    over = [r["overshoot_ratio"] for r in runs]
    settle = [r["settle_time_s"] for r in runs]
    assert peak[0] > peak[1] > peak[2]
    assert over[0] > over[1] > over[2] > 0.05
    assert settle[0] > settle[1] >= settle[2]


def test_fig_7_1_2_a_longer_step_time_overshoots_more(tmp_path: Path) -> None:
    """Kp 100, v1 0.1 m/s: ts 0.1 s overshoots more than 0.04 s (the hold adds lag)."""
    fast, slow = (_straight(tmp_path, 100, ts, 0.1) for ts in (0.04, 0.1))
    assert slow["overshoot_ratio"] > fast["overshoot_ratio"] > 0.1


@pytest.mark.long(reason="several robot runs")
def test_pi_with_ki_0_001_oscillates_like_p_with_a_lower_amplitude(tmp_path: Path) -> None:
    """Sec. 7.3 on the same circle: "the same oscillations ... but the amplitude is lower". With
    the annex's integration step (0.01 Ki e per tick) Ki 0.001 moves the amplitude by well under
    1 %; Ki 0.1 shows the same direction, larger."""
    p = _run(tmp_path, "line_circle_pi", f"{CTRL}.ki=0")["oscillation_amplitude_m"]
    pi = _run(tmp_path, "line_circle_pi")["oscillation_amplitude_m"]
    pi_strong = _run(tmp_path, "line_circle_pi", f"{CTRL}.ki=0.1")["oscillation_amplitude_m"]
    assert pi < p
    assert (p - pi) / p < 0.01
    assert pi_strong < pi


@pytest.mark.long(reason="several robot runs")
def test_away_from_the_sensor_edge_the_step_time_does_not_matter_on_the_circle(
        tmp_path: Path) -> None:
    """kartci's circle result, unlike the source document's: at r = 0.45 m (steady offset about 5.3
    mm) ts 0.1 s keeps the sensor within 8 mm like 0.01 s does, with the source document's ideal
    wheels and even with the source document's Gazebo robot and a frame of camera latency. The
    loop's delay margin (about 0.3 s at Kp 50) is three times the longest step time."""
    for extra in ([f"{MODEL}.wheel_time_constant_s=0"],
                  [*SEED_GAZEBO, "agents.lt0.sensors.line_sensor.latency_frames=1"]):
        for ts in (0.01, 0.1):
            m = _run(tmp_path, "line_circle_grid", "world.course.radius_m=0.45",
                     f"{CTRL}.period_s={ts}", "duration_s=20", *extra)
            assert m["line_lost"] == 0 and m["cross_track_max_m"] < 0.0065, (extra, ts)


@pytest.mark.long(reason="several robot runs")
def test_at_the_sensor_edge_the_source_documents_circle_result_appears(tmp_path: Path) -> None:
    """r = 0.36 m, the source document's Gazebo robot: the steady offset sits at 7.5 mm, on the edge
    of the 8 mm range, and there ts 0.01 s stays within while ts 0.04 s loses the line."""
    fast = _run(tmp_path, "line_circle_edge_fast", "world.course.radius_m=0.36")
    slow = _run(tmp_path, "line_circle_edge_slow", "world.course.radius_m=0.36",
                f"{CTRL}.period_s=0.04")
    assert fast["line_lost"] == 0 and fast["cross_track_max_m"] < 0.008
    assert slow["line_lost"] == 1


@pytest.mark.parametrize("wheels", ["30 g (URDF)", "1 kg, 1 kg m^2 (SDF default)"])
def test_the_annex_set_velocity_drive_contradicts_the_source_documents_straight_line(
        tmp_path: Path, wheels: str) -> None:
    """Gazebo's Joint::SetVelocity once per tick (annex TestSensor.cc) sets the wheels' spin and
    leaves them free until the next tick. Modelled literally, with either wheel mass, the robot
    loses the straight line at Kp 100, ts 0.06 s, v1 0.1 m/s: the source document's own example of a
    settled second-order response (Fig. 7.1.1), which the ideal wheels of Sec. 6.5 give (the Fig.
    7.1.3 test). So the source document's robot drove as if its wheels were ideal."""
    mass = ["1", "1"] if wheels.startswith("1 kg") else ["0.03", "1.84e-05"]
    m = _run(tmp_path, "line_straight_grid", "duration_s=10", f"{MODEL}.wheel_drive=set_velocity",
             f"{MODEL}.wheel_mass_kg={mass[0]}", f"{MODEL}.wheel_inertia_kgm2={mass[1]}")
    assert m["line_lost"] == 1
