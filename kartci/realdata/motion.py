"""Metrics of any robot's recorded motion (`motion`) and of a pose estimate against the
reference (`localization`): what a real log can be scored on without a simulator."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
from pydantic import Field

from kartci.metrics import ScoreContext
from kartci.metrics.base import DEFS, Direction, Metric, MetricDef
from kartci.metrics.kart import kart_track, lap_crossings
from kartci.spec.models import MetricParams
from kartci.track import TRACK_TOPIC, track_from_text

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
LOCALIZATION_DEFS = {
    "ape_rmse_m": MetricDef("m", Direction.LOWER, 0.01, 0.1, "absolute pose error of the "
                            "estimate, translation RMSE after time association (evo_ape)"),
    "ape_max_m": MetricDef("m", Direction.LOWER, 0.02, 0.1, "largest absolute position error"),
    "rpe_rmse_m": MetricDef("m", Direction.LOWER, 0.01, 0.1, "relative pose error per metre "
                            "driven, translation RMSE (evo_rpe --delta 1 --delta_unit m)"),
}


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


class LocalizationParams(MetricParams):
    """Which topic holds the estimate judged against the agent's odometry."""

    estimate: str = Field("estimate", description="the estimate's topic (nav_msgs/Odometry), "
                          "relative to the agent's namespace or absolute")
    max_diff_s: float = Field(0.01, gt=0.0, description="largest stamp difference for "
                              "associating an estimate with a reference pose, s (evo's 0.01)")
    rpe_delta_m: float = Field(1.0, gt=0.0, description="RPE pose-pair distance, m")


def localization_metrics(ctx: ScoreContext, params: LocalizationParams) -> list[Metric]:
    """APE and RPE (translation) of the estimate against the reference odometry, as evo."""
    from kartci.errors import LogError
    from kartci.metrics.trajectory import DeltaUnit, Trajectory, ape, associate, rpe

    est = ctx.table(params.estimate)
    if est is None or est.empty:
        raise LogError(f"{ctx.path}: no {params.estimate} messages of agent {ctx.agent} to "
                       "judge as the pose estimate")
    ref_t, est_t = associate(Trajectory.from_odometry(ctx.odom), Trajectory.from_odometry(est),
                             max_diff_s=params.max_diff_s)
    a = ape(ref_t, est_t)
    r = rpe(ref_t, est_t, params.rpe_delta_m, DeltaUnit.METERS)
    return [_m("ape_rmse_m", a.rmse, LOCALIZATION_DEFS, count=a.count),
            _m("ape_max_m", a.max, LOCALIZATION_DEFS),
            _m("rpe_rmse_m", r.rmse, LOCALIZATION_DEFS, count=r.count)]
