"""Sim-vs-real divergence: the simulated robot driven by the log's commands, over the whole log
and over sliding windows that re-start the sim from the recorded state every W seconds (so
drift does not hide model error), compared signal by signal with the log."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from pydantic import Field

from kartci.core import Direction, Metric, MetricDef, MetricParams
from kartci.errors import LogError
from kartci.metrics import ScoreContext
from kartci.metrics.trajectory import DeltaUnit, Trajectory, TrajectoryError, ape, rpe

if TYPE_CHECKING:  # scoring needs neither; the plant brings the simulator (start-up)
    from kartci.realdata.drive import Drive
    from kartci.realdata.plant import Plant

SIGNALS = (("x", "m"), ("y", "m"), ("yaw", "rad"), ("speed", "mps"), ("yaw_rate", "radps"))
SIM_WINDOWS, SIM_WHOLE = "sim/odom_windows", "sim/odom_whole"


def _d(unit: str, text: str, abs_tol: float) -> MetricDef:
    return MetricDef(unit, Direction.LOWER, abs_tol, 0.2, text)


DEFS = {
    "simreal_ape_window_rmse_m": _d("m", "sim-vs-log position error (APE, translation RMSE) "
                                    "with the sim re-started from the log every window", 0.01),
    "simreal_ape_window_max_m": _d("m", "largest such position error", 0.02),
    "simreal_ape_whole_rmse_m": _d("m", "APE of one sim run over the whole log (drift "
                                   "included)", 0.05),
    "simreal_rpe_whole_rmse_m": _d("m", "RPE per metre driven of the whole-log sim run", 0.01),
    **{f"simreal_{name}_rms_{unit}": _d(unit.replace("mps", "m/s").replace("radps", "rad/s"),
                                        f"RMS of the windowed sim's {name.replace('_', ' ')} "
                                        "minus the log's", 0.005) for name, unit in SIGNALS},
}


class SimrealParams(MetricParams):
    """How the sim was run against the log (recorded for the metrics and for traceability)."""

    window_s: float = Field(2.0, gt=0.0, description="window after which the sim re-starts "
                            "from the recorded state, s")
    scenario: str = Field("", description="the scenario whose world and robot were simulated")
    overrides: tuple[str, ...] = Field((), description="its --set overrides (calibrated "
                                       "parameters among them)")


def window_starts(duration_s: float, window_s: float) -> list[float]:
    """Start times of the windows covering [0, duration]; the last one may be shorter."""
    n = max(1, math.ceil(duration_s / window_s - 1e-9))
    return [i * window_s for i in range(n)]


def run_windows(plant: Plant, drive: Drive, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """The sim's state at every recorded sample, each window re-started from the log."""
    starts = window_starts(drive.duration_s, window_s)
    ts, states = [], []
    for i, t0 in enumerate(starts):
        last = i == len(starts) - 1
        t1 = drive.duration_s if last else t0 + window_s
        t, sim = plant.run(t0, t1)
        keep = t <= t1 if last else t < t1 - 1e-9
        ts.append(t[keep])
        states.append(sim[keep])
    return np.concatenate(ts), np.concatenate(states)


def run_whole(plant: Plant, drive: Drive) -> tuple[np.ndarray, np.ndarray]:
    """One sim run over the whole log from its first state."""
    return plant.run(0.0, drive.duration_s)


def residuals(real: np.ndarray, sim: np.ndarray) -> np.ndarray:
    """Per sample, sim minus log: x, y (m), yaw (rad, wrapped), speed (m/s), yaw rate (rad/s)."""
    dyaw = (sim[:, 2] - real[:, 2] + math.pi) % (2 * math.pi) - math.pi
    speed = np.hypot(sim[:, 3], sim[:, 4]) - np.hypot(real[:, 3], real[:, 4])
    return np.column_stack([sim[:, 0] - real[:, 0], sim[:, 1] - real[:, 1], dyaw, speed,
                            sim[:, 5] - real[:, 5]])


def trajectory(t: np.ndarray, states: np.ndarray) -> Trajectory:
    """A planar state series as a Trajectory (z = 0, yaw about z)."""
    return Trajectory.planar(t, states[:, 0], states[:, 1], states[:, 2])


def divergence(t: np.ndarray, real_w: np.ndarray, sim_w: np.ndarray, t_whole: np.ndarray,
               real_whole: np.ndarray, sim_whole: np.ndarray) -> dict[str, float]:
    """The divergence metrics (see DEFS) of a windowed and a whole-log sim run."""
    win = ape(trajectory(t, real_w), trajectory(t, sim_w))
    whole_ref, whole_sim = trajectory(t_whole, real_whole), trajectory(t_whole, sim_whole)
    whole = ape(whole_ref, whole_sim)
    try:
        rel = rpe(whole_ref, whole_sim, 1.0, DeltaUnit.METERS).rmse
    except TrajectoryError:  # a log shorter than a metre has no pose pair a metre apart
        rel = math.nan
    res = residuals(real_w, sim_w)
    out = {"simreal_ape_window_rmse_m": win.rmse, "simreal_ape_window_max_m": win.max,
           "simreal_ape_whole_rmse_m": whole.rmse, "simreal_rpe_whole_rmse_m": rel}
    for i, (name, unit) in enumerate(SIGNALS):
        out[f"simreal_{name}_rms_{unit}"] = math.sqrt(float(np.mean(res[:, i] ** 2)))
    return out


def _series(ctx: ScoreContext, topic: str) -> tuple[np.ndarray, np.ndarray]:
    table = ctx.table(topic)
    if table is None or table.empty:
        raise LogError(f"{ctx.path}: no /{ctx.agent}/{topic}: not a kartci simreal log")
    states = table[["x", "y", "yaw", "vx", "vy", "wz"]].to_numpy(dtype=float).copy()
    states[:, 2] = np.unwrap(states[:, 2])
    return table["t"].to_numpy(dtype=float), states


def simreal_metrics(ctx: ScoreContext, params: SimrealParams) -> list[Metric]:
    """Divergence of the sim's recorded runs from the log's odometry (a simreal run log)."""
    t_r, real = _series(ctx, "odom")
    t_w, sim_w = _series(ctx, SIM_WINDOWS)
    t_a, sim_a = _series(ctx, SIM_WHOLE)

    def at(t: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(t, t_r, real[:, i]) for i in range(6)])

    values = divergence(t_w, at(t_w), sim_w, t_a, at(t_a), sim_a)
    return [Metric(name, float(v), DEFS[name].unit) for name, v in values.items()]
