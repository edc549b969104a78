"""Racing metrics from a run log: clearance to obstacles and other karts (outline to outline),
overtakes (lapping passes included), the MPCC's solver statistics, and the time its watchdog
held the kart (a loss of control is the kart's fault, not the solver's: counted apart)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from kartci.core import Direction, Metric, MetricDef
from kartci.metrics.outline import Placed, box, fixed, outline_gap_m
from kartci.robots.gokart.mpcc.recovery import MpccStatus
from kartci.worlds.parts import Box

SLACK_DEF = MetricDef("m", Direction.LOWER, 0.05, 0.2, "largest slack the MPCC applied (its "
                      "first predicted stage's, the state its command leads to, from "
                      "mpcc/stats): how far past its track bounds it drove by its own model; "
                      "the same slack relaxes its speed and friction limits")


def min_clearance_m(mine: Placed, obstacles: tuple[Box, ...], others: list[Placed]) -> float:
    """Smallest gap between this kart's outline and any obstacle or other kart's outline along
    the run (poses paired by index: odometry is stamped on the same ticks); nan when there is
    nothing to keep clear of."""
    poses = len(mine[0])
    gaps = [outline_gap_m(mine, [fixed(box(b.center_m, b.size_m[0], b.size_m[1], b.yaw_rad),
                                       poses)]) for b in obstacles]
    gaps += [outline_gap_m(mine, other) for other in others]
    best = min((float(g.min()) for g in gaps if len(g)), default=math.inf)
    return best if math.isfinite(best) else math.nan


def overtakes(mine: np.ndarray, others: list[np.ndarray], lap_m: float) -> int:
    """Net passes: times this kart's progress (m, unwrapped) went from behind to ahead of
    another's on the track, minus the times it was passed back (side-by-side flicker cancels
    out). On a closed track of `lap_m` it passes the other whenever the gap in progress
    crosses a whole number of laps, so lapping a slower kart counts as a pass too."""
    count = 0
    for other in others:
        n = min(len(mine), len(other))
        gap = (mine[:n] - other[:n]) / lap_m
        laps = np.floor(gap[gap != np.round(gap)])  # level with the other: neither side yet
        if len(laps) >= 2:
            count += int(laps[-1] - laps[0])
    return count


WATCHDOG = {MpccStatus.LOSS_OF_CONTROL.value: "loss_of_control_s",
            MpccStatus.RECOVERING.value: "recovering_s"}  # status -> metric (time in it)


def watchdog_seconds(stats: pd.DataFrame) -> dict[str, float]:
    """Sim time the watchdog held the kart in each of its states, s: the steps logged with
    that status times the control period (the median step of the stats' stamps)."""
    t = stats["t"].to_numpy(dtype=float)
    period = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    status = stats["status"].astype(str)
    return {name: float((status == value).sum()) * period for value, name in WATCHDOG.items()}


def solver_values(stats: pd.DataFrame) -> tuple[int, dict[str, float]]:
    """(failed solves, wall-clock solve-time statistics in ms). A failed solve is an
    unsuccessful step the watchdog did not make: its braking steps (no solve) and a stall's
    successful fresh plan (`Stalled`) are not the solver's failures."""
    ms = stats["solve_ms"].to_numpy(dtype=float)
    watchdog = stats["status"].astype(str).isin([*WATCHDOG, MpccStatus.STALLED.value])
    failures = int((~stats["success"].astype(bool) & ~watchdog).sum())
    return failures, {"solve_ms_median": float(np.median(ms)),
                      "solve_ms_p95": float(np.percentile(ms, 95)),
                      "solve_ms_max": float(ms.max())}


def race_metrics(scenario: Any, agent: str, paths: Mapping[str, pd.DataFrame], lap_m: float,
                 outlines: Mapping[str, Placed], stats: pd.DataFrame | None) -> list[Metric]:
    """Clearance, overtakes and solver statistics, where the run has what they need.
    `outlines` holds the robots that have one, placed along their paths: the others are not
    kept clear of."""
    obstacles = getattr(scenario.world, "obstacles", ())
    others = [n for n in paths if n != agent]
    out = []
    if obstacles or others:
        gap = min_clearance_m(outlines[agent], obstacles,
                              [outlines[n] for n in others if n in outlines])
        out.append(Metric("min_clearance_m", gap, "m"))
    if others:
        theirs = [paths[n]["s_total"].to_numpy() for n in others]
        out.append(Metric("overtakes", float(overtakes(paths[agent]["s_total"].to_numpy(),
                                                       theirs, lap_m)), "count"))
    if stats is not None and not stats.empty:
        failures, timing = solver_values(stats)
        out.append(Metric("solver_failures", float(failures), "count"))
        out += [Metric(name, value, "s") for name, value in watchdog_seconds(stats).items()]
        if "max_slack_m" in stats:
            out.append(Metric("max_slack_m", float(stats["max_slack_m"].max()), "m"))
        out += [Metric(name, value, "ms") for name, value in timing.items()]
    return out
