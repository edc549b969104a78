"""kartci's own metric sets, registered through entry points like any team's."""

from __future__ import annotations

from typing import Any

from kartci.core import Metric, MetricSet
from kartci.metrics import ScoreContext, footprint_m, recorded_track
from kartci.metrics.defs import DEFS
from kartci.metrics.detection import DEFS as DETECTION_DEFS
from kartci.metrics.detection import DetectionMetricsParams, detection_metrics
from kartci.metrics.kart import kart_metrics, kart_track
from kartci.metrics.localization import DEFS as LOCALIZATION_DEFS
from kartci.metrics.localization import LocalizationMetricsParams, localization_metrics
from kartci.metrics.race import kart_rects, race_metrics


def _defs(*names: str) -> dict[str, Any]:
    return {n: DEFS[n] for n in names}


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


def _rects(ctx: ScoreContext) -> dict[str, Any]:
    """Every robot's footprint along its path, once per log (robots without one are left out)."""
    out = {}
    for a in ctx.scenario.agents:
        outline = footprint_m(ctx.scenario, a)
        if outline is not None:
            out[a] = kart_rects(ScoreContext(ctx.scenario, ctx.tables, ctx.path, a).odom, outline)
    return out


def _race(ctx: ScoreContext, params: Any) -> list[Metric]:
    rects = ctx.shared("kart_rects", lambda: _rects(ctx))
    return race_metrics(ctx.scenario, ctx.agent, _paths(ctx), rects, ctx.table("mpcc/stats"))


LAPS = MetricSet(
    "laps",
    _defs("laps_completed", "lap_times_s", "best_lap_s", "collisions", "off_track_s",
          "max_speed_mps", "mean_speed_mps", "progress_m", "cross_track_rms_m"),
    _laps, None, ("gokart",),
    "laps and lap times, collisions, time off track, speed, progress, distance from the "
    "centreline")
RACE = MetricSet(
    "race",
    _defs("min_clearance_m", "overtakes", "solver_failures", "solve_ms_median", "solve_ms_p95",
          "solve_ms_max"),
    _race, None, ("gokart",),
    "clearance to obstacles and other karts, overtakes, MPCC solver statistics")
LOCALIZATION = MetricSet(
    "localization", LOCALIZATION_DEFS, localization_metrics, LocalizationMetricsParams, (),
    "localization estimate vs ground truth: APE / RPE (evo's conventions), convergence from "
    "the initial guess, divergence events")
DETECTION = MetricSet(
    "detection", DETECTION_DEFS, detection_metrics, DetectionMetricsParams, (),
    "obstacle detections vs ground-truth boxes: recall within range, precision, position "
    "error, static/dynamic accuracy, latency")
