"""The go-kart's metric sets: `laps` (laps, collisions, time off track, speed, progress),
`race` (clearance, overtakes, MPCC solver statistics) and `handling` (sideslip, spins, tyre
saturation, stalled time), from a run log."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from kartci.core import Direction, Metric, MetricDef, MetricSet
from kartci.metrics import ScoreContext, outline_of, recorded_track
from kartci.metrics.defs import defs_of
from kartci.metrics.outline import placed
from kartci.metrics.progress import kart_track, lap_crossings
from kartci.robots.gokart.handling import HANDLING_DEFS, HandlingParams, handling_metrics
from kartci.robots.gokart.params import GokartModel
from kartci.robots.gokart.race import SLACK_DEF, race_metrics
from kartci.scenario.models import Scenario
from kartci.worlds.track import Track

# the kart's own metrics; the shared ones (laps, speeds, collisions, clearance) are in
# kartci.metrics.defs
KART_DEFS: dict[str, MetricDef] = {
    "off_track_s": MetricDef("s", Direction.LOWER, 0.1, 0.10,
                             "time with any wheel outside the track bounds"),
    "overtakes": MetricDef("count", Direction.HIGHER, 0.0, 0.0,
                           "net passes of other karts (passes minus times passed; lapping a "
                           "kart is a pass)"),
    "solver_failures": MetricDef("count", Direction.LOWER, 0.0, 0.0,
                                 "MPCC solves that failed or hit the iteration cap (the kart "
                                 "braked); the watchdog's steps are counted apart "
                                 "(`loss_of_control_s`, `recovering_s`)"),
    "loss_of_control_s": MetricDef("s", Direction.LOWER, 0.1, 0.10,
                                   "sim time of the MPCC's control steps that found the kart "
                                   "out of control (sideslip or yaw rate beyond the "
                                   "watchdog's limits: it brakes straight from there), from "
                                   "mpcc/stats"),
    "recovering_s": MetricDef("s", Direction.LOWER, 0.1, 0.10,
                              "sim time the MPCC spent braking straight after a loss of "
                              "control, until the kart no longer slid, from mpcc/stats"),
    "solve_ms_median": MetricDef("ms", Direction.LOWER, 5.0, 1.0, "median MPCC solve time",
                                 timing=True),
    "solve_ms_p95": MetricDef("ms", Direction.LOWER, 5.0, 1.0, "95th percentile solve time",
                              timing=True),
    "solve_ms_max": MetricDef("ms", Direction.LOWER, 20.0, 2.0, "slowest solve", timing=True),
}
DEFS = {**defs_of("laps_completed", "lap_times_s", "best_lap_s", "collisions", "max_speed_mps",
                  "mean_speed_mps", "progress_m", "cross_track_rms_m", "min_clearance_m"),
        **KART_DEFS}


def _of(*names: str) -> dict[str, MetricDef]:
    return {n: DEFS[n] for n in names}


def _m(name: str, value: float, **extra: object) -> Metric:
    return Metric(name, float(value), DEFS[name].unit, dict(extra))


def kart_metrics(scenario: Scenario, agent: str, track: Track, tr: pd.DataFrame,
                 collisions: pd.DataFrame | None) -> list[Metric]:
    """Lap, collision and track metrics from the agent's `kart_track` path."""
    model = scenario.agents[agent].model
    assert isinstance(model, GokartModel)
    t, total = tr["t"].to_numpy(), tr["s_total"].to_numpy()
    laps = np.diff([0.0, *lap_crossings(t, total, track.length_m)])
    lap_list = [round(float(x), 4) for x in laps]

    wheels = np.asarray(model.wheel_xy_m)
    yaw = tr["yaw"].to_numpy()
    out_any = np.zeros(len(tr), bool)
    for wx, wy in wheels:
        px = tr["x"].to_numpy() + wx * np.cos(yaw) - wy * np.sin(yaw)
        py = tr["y"].to_numpy() + wx * np.sin(yaw) + wy * np.cos(yaw)
        _, lat, w_right, w_left = track.project(np.column_stack([px, py]))
        out_any |= (lat > w_left) | (lat < -w_right)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0

    events = [] if collisions is None else [
        {"time_s": round(float(t_c), 4), "other": str(other), "impulse_ns": round(float(imp), 3)}
        for t_c, other, imp in zip(collisions["t"].to_numpy(), collisions["other"].tolist(),
                                   collisions["impulse_ns"].to_numpy(), strict=True)]
    return [
        _m("laps_completed", len(lap_list)),
        _m("lap_times_s", float(np.mean(laps)) if len(laps) else math.nan, laps=lap_list),
        _m("best_lap_s", float(np.min(laps)) if len(laps) else math.nan),
        _m("collisions", len(events), events=events),
        _m("off_track_s", float(out_any.sum()) * dt),
        _m("max_speed_mps", float(tr["speed"].max())),
        _m("mean_speed_mps", float(tr["speed"].mean())),
        _m("progress_m", float(total[-1] - total[0])),
        _m("cross_track_rms_m", math.sqrt(float(np.mean(tr["offset"] ** 2)))),
    ]


def _paths(ctx: ScoreContext) -> dict[str, Any]:
    """Every kart's path along the track, once per log: each agent's metrics use them all."""
    track = ctx.shared("track", lambda: recorded_track(ctx.tables, ctx.path))
    return ctx.shared("kart_paths", lambda: {
        a: kart_track(track, ScoreContext(ctx.scenario, ctx.tables, ctx.path, a).odom)
        for a in ctx.scenario.agents})


def _laps(ctx: ScoreContext, params: Any) -> list[Metric]:
    track = ctx.shared("track", lambda: recorded_track(ctx.tables, ctx.path))
    return kart_metrics(ctx.scenario, ctx.agent, track, _paths(ctx)[ctx.agent],
                        ctx.table("collision"))


def _outlines(ctx: ScoreContext) -> dict[str, Any]:
    """Every robot's outline placed along its path, once per log (robots without one are left
    out)."""
    out = {}
    for a in ctx.scenario.agents:
        outline = outline_of(ctx, a)
        if outline is not None:
            odom = ScoreContext(ctx.scenario, ctx.tables, ctx.path, a).odom
            out[a] = placed(outline, odom[["x", "y", "yaw"]].to_numpy())
    return out


def _race(ctx: ScoreContext, params: Any) -> list[Metric]:
    track = ctx.shared("track", lambda: recorded_track(ctx.tables, ctx.path))
    outlines = ctx.shared("kart_outlines", lambda: _outlines(ctx))
    return race_metrics(ctx.scenario, ctx.agent, _paths(ctx), track.length_m, outlines,
                        ctx.table("mpcc/stats"))


def _handling(ctx: ScoreContext, params: HandlingParams) -> list[Metric]:
    return handling_metrics(ctx.odom, _paths(ctx)[ctx.agent], ctx.table("tyres"), params)


LAPS = MetricSet(
    "laps",
    _of("laps_completed", "lap_times_s", "best_lap_s", "collisions", "off_track_s",
        "max_speed_mps", "mean_speed_mps", "progress_m", "cross_track_rms_m"),
    _laps, None, ("gokart",),
    "laps and lap times, collisions, time off track, speed, progress, distance from the "
    "centreline")
RACE = MetricSet(
    "race",
    {**_of("min_clearance_m", "overtakes", "solver_failures", "loss_of_control_s",
           "recovering_s", "solve_ms_median", "solve_ms_p95", "solve_ms_max"),
     "max_slack_m": SLACK_DEF},
    _race, None, ("gokart",),
    "clearance to obstacles and other karts (outline to outline), overtakes (lapping passes "
    "included), MPCC solver statistics and slack, time in the MPCC watchdog's loss of control "
    "and recovery")
HANDLING = MetricSet(
    "handling", HANDLING_DEFS, _handling, HandlingParams, ("gokart",),
    "how the kart drove: sideslip (max, RMS), time spinning, time with a tyre at its grip, "
    "time stalled on the track")
