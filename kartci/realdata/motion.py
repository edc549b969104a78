"""Metrics of any robot's recorded motion (`motion`) and of a pose estimate against the
reference (the `localization` metric set of `kartci.metrics.localization`): what a real log can
be scored on without a simulator."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from kartci.core import Direction, Metric, MetricDef
from kartci.metrics import ScoreContext
from kartci.metrics.defs import DEFS
from kartci.metrics.progress import kart_track, lap_crossings
from kartci.worlds.track import TRACK_TOPIC, track_from_text

MOTION_DEFS = {
    "duration_s": MetricDef("s", Direction.EQUAL, 0.5, 0.02, "time from the first pose to the "
                            "last"),
    "distance_m": MetricDef("m", Direction.EQUAL, 0.5, 0.05, "path length of base_link"),
    "mean_speed_mps": DEFS["mean_speed_mps"],
    "max_speed_mps": DEFS["max_speed_mps"],
    "max_yaw_rate_radps": MetricDef("rad/s", Direction.EQUAL, 0.1, 0.1,
                                    "largest yaw rate (odometry twist)"),
}
TRACK_DEFS = {n: DEFS[n] for n in ("laps_completed", "lap_times_s", "best_lap_s",
                                    "progress_m", "cross_track_rms_m", "collisions")}
def _m(name: str, value: float, defs: dict[str, MetricDef], **extra: Any) -> Metric:
    return Metric(name, float(value), defs[name].unit, dict(extra))


def motion_metrics(ctx: ScoreContext, params: Any) -> list[Metric]:
    """Duration, distance, speeds and yaw rate of the agent's odometry; laps, lap times,
    progress and cross-track error when the log holds a track."""
    odom = ctx.odom
    t = odom["t"].to_numpy()
    xy = odom[["x", "y"]].to_numpy()
    speed = np.hypot(odom["vx"].to_numpy(), odom["vy"].to_numpy())
    out = [_m("duration_s", t[-1] - t[0], MOTION_DEFS),
           _m("distance_m", float(np.sum(np.hypot(*np.diff(xy, axis=0).T))), MOTION_DEFS),
           _m("mean_speed_mps", float(np.mean(speed)), MOTION_DEFS),
           _m("max_speed_mps", float(np.max(speed)), MOTION_DEFS),
           _m("max_yaw_rate_radps", float(np.max(np.abs(odom["wz"].to_numpy()))), MOTION_DEFS)]
    table = ctx.tables.get(TRACK_TOPIC)
    if table is not None and not table.empty:
        out += _track_metrics(odom, str(table["data"].iloc[0]))
    collisions = ctx.table("collision")
    if collisions is not None:  # recorded: each one an event, as a run's
        events = [{"time_s": round(float(t - odom["t"].iloc[0]), 4), "other": str(o)}
                  for t, o in zip(collisions["t"], collisions["other"], strict=True)]
        out.append(_m("collisions", len(events), TRACK_DEFS, events=events))
    return out


def _track_metrics(odom: pd.DataFrame, text: str) -> list[Metric]:
    track = track_from_text(text, "recorded track")
    tr = kart_track(track, odom.assign(t=odom["t"] - odom["t"].iloc[0]))
    t, total = tr["t"].to_numpy(), tr["s_total"].to_numpy()
    laps = np.diff([0.0, *lap_crossings(t, total, track.length_m)])
    return [_m("laps_completed", len(laps), TRACK_DEFS),
            _m("lap_times_s", float(np.mean(laps)) if len(laps) else math.nan, TRACK_DEFS,
               laps=[round(float(x), 4) for x in laps]),
            _m("best_lap_s", float(np.min(laps)) if len(laps) else math.nan, TRACK_DEFS),
            _m("progress_m", float(total[-1] - total[0]), TRACK_DEFS),
            _m("cross_track_rms_m", math.sqrt(float(np.mean(tr["offset"] ** 2))), TRACK_DEFS)]
