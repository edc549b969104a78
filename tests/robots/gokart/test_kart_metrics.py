"""The kart's racing and handling metrics on a synthetic log whose answers are known in closed
form: two karts on a circular track, one sliding, stopping, saturating a tyre and lapping the
other, its MPCC losing control once, recovering, stalling and failing two solves."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kartci.logs import McapLogWriter, header, msg
from kartci.logs.types import SCENARIO_TOPIC
from kartci.metrics import Metric, compute
from kartci.project import current as active_project
from kartci.robots.gokart.race import overtakes
from kartci.scenario import load_scenario
from kartci.sim.messages import ZEROS36, pose, vec
from kartci.sim.urdf import robot_descriptions
from kartci.worlds.track import TRACK_TOPIC

R_M = 8.0  # the track: a circle, 2.5 m either side of its centreline
DT_S, SAMPLES = 0.02, 1000  # 20 s of odometry at 50 Hz
STATS_DT_S = 0.05  # the MPCC's control period: 20 Hz
# its steps' (success, status): 10 solved, one loss of control and 6 recovering steps (the
# watchdog's: no solve), a stall whose fresh plan solved, two failed solves, 20 solved
STEPS = ([(True, "Solved")] * 10 + [(False, "Loss_of_control")] + [(False, "Recovering")] * 6
         + [(False, "Stalled"), (False, "Infeasible_Problem_Detected"),
            (False, "Maximum_Iterations_Exceeded")] + [(True, "Solved")] * 20)
WHEELS = ("rear_left_wheel_joint", "rear_right_wheel_joint", "front_left_wheel_joint",
          "front_right_wheel_joint")


def _kart0(t: float) -> tuple[float, float, float]:
    """Progress (m), speed (m/s) and sideslip (deg) of the kart under test: 5 m/s, standing
    still from 8 s to 12 s, sliding at 40 deg from 2 s to 4 s and at -50 deg from 14 s to 15 s."""
    if 8.0 <= t < 12.0:
        return 40.0, 0.0, 0.0
    s = 5.0 * t if t < 8.0 else 40.0 + 5.0 * (t - 12.0)
    return s, 5.0, 40.0 if 2.0 <= t < 4.0 else -50.0 if 14.0 <= t < 15.0 else 0.0


def _kart1(t: float) -> tuple[float, float, float]:
    """A slow kart 10 m ahead at the start, 0.5 m/s: lapped by kart0 after about 19 s."""
    return 10.0 + 0.5 * t, 0.5, 0.0


def _odom(t_ns: int, ns: str, s_m: float, v_mps: float, slip_deg: float) -> object:
    a = s_m / R_M
    yaw = a + math.pi / 2
    b = math.radians(slip_deg)
    q = (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))
    return msg("nav_msgs/msg/Odometry", header=header(t_ns, "map"),
               child_frame_id=f"{ns}/base_link",
               pose=msg("geometry_msgs/msg/PoseWithCovariance",
                        pose=pose((R_M * math.cos(a), R_M * math.sin(a), 0.0), q),
                        covariance=ZEROS36),
               twist=msg("geometry_msgs/msg/TwistWithCovariance",
                         twist=msg("geometry_msgs/msg/Twist",
                                   linear=vec(v_mps * math.cos(b), v_mps * math.sin(b), 0.0),
                                   angular=vec(0.0, 0.0, 0.0)), covariance=ZEROS36))


def _tyres(t_ns: int, t: float) -> object:
    """Grip 1000 N each; the rear left tyre makes 960 N from 5 s to 6 s, the front right 940 N
    (just under 95 %) all along."""
    rl = 960.0 if 5.0 <= t < 6.0 else 100.0
    return msg("kartci_msgs/msg/TyreForces", header=header(t_ns, "kart0/base_link"),
               wheel=list(WHEELS), fx_n=np.array([rl * 0.6, 0.0, 0.0, 940.0]),
               fy_n=np.array([rl * 0.8, 0.0, 0.0, 0.0]), grip_n=np.full(4, 1000.0))


def _write(path: Path) -> None:
    scenario = load_scenario("multi_agent", project=active_project())
    w = McapLogWriter(path)
    w.write(SCENARIO_TOPIC, msg("std_msgs/msg/String", data=scenario.model_dump_json()), 0)
    rows = [f"{R_M * math.cos(a):.9f},{R_M * math.sin(a):.9f},2.5,2.5"
            for a in np.arange(400) * (2 * math.pi / 400)]
    text = "# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + "\n".join(rows) + "\n"
    w.write(TRACK_TOPIC, msg("std_msgs/msg/String", data=text), 0)
    for topic, m in robot_descriptions(scenario):
        w.write(topic, m, 0)
    for k in range(SAMPLES):
        t_ns = k * 20_000_000
        t = t_ns * 1e-9
        w.write("/kart0/odom", _odom(t_ns, "kart0", *_kart0(t)), t_ns)
        w.write("/kart1/odom", _odom(t_ns, "kart1", *_kart1(t)), t_ns)
        w.write("/kart0/tyres", _tyres(t_ns, t), t_ns)
    slacks = (0.0, 0.3, 1.72, 0.1)
    for k, (success, status) in enumerate(STEPS):
        t_ns = round(k * STATS_DT_S * 1e9)
        w.write("/kart0/mpcc/stats", msg(
            "kartci_msgs/msg/SolverStats", header=header(t_ns, "map"), success=success,
            status=status, solve_ms=1.0, iterations=3, cost=0.0, failures=0,
            max_slack_m=slacks[k] if k < len(slacks) else 0.0), t_ns)
    w.close()


@pytest.fixture(scope="module")
def metrics(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Metric]:
    path = tmp_path_factory.mktemp("synthetic") / "run.mcap"
    _write(path)
    return compute(path)[1]


def test_sideslip_and_spin_time(metrics: dict[str, Metric]) -> None:
    """Above 2 m/s: 800 samples, 100 at 40 deg and 50 at 50 deg (the standing ones do not
    count)."""
    assert metrics["kart0.max_sideslip_deg"].value == pytest.approx(50.0)
    assert metrics["kart0.rms_sideslip_deg"].value == pytest.approx(
        math.sqrt((100 * 40.0**2 + 50 * 50.0**2) / 800))
    assert metrics["kart0.spin_s"].value == pytest.approx(150 * DT_S)  # above 30 deg
    # a kart never faster than 2 m/s has no sideslip to speak of
    assert metrics["kart1.max_sideslip_deg"].value == 0.0
    assert metrics["kart1.spin_s"].value == 0.0


def test_tyre_saturation_stalled_time_and_slack(metrics: dict[str, Metric]) -> None:
    assert metrics["kart0.tyre_saturated_s"].value == pytest.approx(1.0)
    assert "kart1.tyre_saturated_s" not in metrics  # its log has no tyre forces
    assert metrics["kart0.stalled_s"].value == pytest.approx(4.0)  # 8 s to 12 s
    assert metrics["kart1.stalled_s"].value == 0.0  # slow, but never below 0.1 m/s
    assert metrics["kart0.max_slack_m"].value == pytest.approx(1.72)
    assert "kart1.max_slack_m" not in metrics  # no MPCC


def test_watchdog_steps_are_timed_apart_from_solver_failures(
        metrics: dict[str, Metric]) -> None:
    """One step found the kart out of control and six braked it straight, at 20 Hz: 0.05 s and
    0.3 s; only the two failed solves are the solver's (the stall's fresh plan solved)."""
    assert metrics["kart0.loss_of_control_s"].value == pytest.approx(1 * STATS_DT_S)
    assert metrics["kart0.recovering_s"].value == pytest.approx(6 * STATS_DT_S)
    assert metrics["kart0.solver_failures"].value == 2
    assert metrics["kart0.loss_of_control_s"].unit == "s"
    assert "kart1.loss_of_control_s" not in metrics  # no MPCC


def test_overtakes_count_the_lapping_pass(metrics: dict[str, Metric]) -> None:
    """kart0 ends 60 m ahead of kart1 on a 50.3 m lap: it passed it, then lapped it."""
    assert metrics["kart0.overtakes"].value == 2
    assert metrics["kart1.overtakes"].value == -2
    assert metrics["kart0.min_clearance_m"].value == 0.0  # they passed through each other


def test_overtake_counting_in_closed_form() -> None:
    behind_then_ahead = np.array([0.0, 1.0, 2.0, 3.0])
    other = np.array([1.5, 1.6, 1.7, 1.8])
    assert overtakes(behind_then_ahead, [other], 100.0) == 1
    assert overtakes(other, [behind_then_ahead], 100.0) == -1
    # 3 m behind on a 10 m lap, then 17 m ahead: a pass and a lapping pass
    assert overtakes(np.array([0.0, 10.0, 20.0]), [np.array([3.0, 3.0, 3.0])], 10.0) == 2
    # side by side, level at one sample: no pass either way
    assert overtakes(np.array([0.0, 1.0, 1.0, 0.9]), [np.ones(4)], 10.0) == 0
