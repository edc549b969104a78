"""The line tracker's metrics (`line_tracking`), computed from a run log's tables and the
scenario recorded in it; `sensor_track` is also what its plots and study draw."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from pydantic import Field

from kartci.core import Direction, Metric, MetricDef, MetricParams, MetricSet
from kartci.core.params import Duration_s, Size_m
from kartci.errors import SpecError
from kartci.metrics import ScoreContext
from kartci.metrics.defs import defs_of
from kartci.robots.line_tracker.params import line_parts
from kartci.scenario.models import Scenario


class LineMetricsParams(MetricParams):
    """Parameters of the line tracker's tracking metrics."""

    transient_s: Duration_s = Field(5.0, description="start-up transient excluded from "
                                    "the cross-track errors, s")
    lost_threshold_m: Size_m = Field(0.021, description="the sensor's range, m: farther "
                                     "from the line axis counts as lost (seed 001 Eq. 6.15: "
                                     "+-0.021 m)")
    settle_band_m: Size_m = Field(0.002, description="the cross-track error band that "
                                  "ends settling (settle_time_s), m")

# the line tracker's own metrics; the shared ones (speed, RMS distance) are in kartci.metrics.defs
LINE_DEFS: dict[str, MetricDef] = {
    "cross_track_max_m": MetricDef("m", Direction.LOWER, 0.0005, 0.10,
                                   "largest such distance after the transient"),
    "line_lost": MetricDef("bool", Direction.EQUAL, 0.0, 0.0,
                           "1 if the sensor point ever left the sensor's range of the line"),
    "completion": MetricDef("fraction", Direction.HIGHER, 0.01, 0.0,
                            "fraction of the course covered while on the line"),
    "settle_time_s": MetricDef("s", Direction.LOWER, 0.5, 0.10,
                               "time after which the cross-track error stays in the settle band"),
}
DEFS = {**defs_of("cross_track_rms_m", "mean_speed_mps"), **LINE_DEFS}


def _m(name: str, value: float, **extra: object) -> Metric:
    return Metric(name, float(value), DEFS[name].unit, dict(extra))


def sensor_track(scenario: Scenario, agent: str, odom: pd.DataFrame) -> pd.DataFrame:
    """Time, sensor-point position, signed offset from the line and progress along the course."""
    world, model = line_parts(scenario, agent)
    lever = model.sensor_point_x_m
    x = odom["x"].to_numpy() + lever * np.cos(odom["yaw"].to_numpy())
    y = odom["y"].to_numpy() + lever * np.sin(odom["yaw"].to_numpy())
    pts = np.column_stack([x, y])
    course = world.course
    return pd.DataFrame({"t": odom["t"].to_numpy(), "x": x, "y": y,
                         "offset": course.offset_m(pts),
                         "progress": course.progress_m(pts),
                         "vx": odom["vx"].to_numpy()})


def line_metrics(scenario: Scenario, agent: str, odom: pd.DataFrame,
                 spec: LineMetricsParams) -> list[Metric]:
    """Tracking error, line lost, completion, speed and settling of one line tracker. A run
    that ends before its start-up transient is over has nothing to score: a SpecError naming
    both times, not NaN errors."""
    if odom.empty:
        return []
    t_end = float(odom["t"].iloc[-1])
    if t_end < spec.transient_s:
        ended = (f"the run ends at {t_end:g} s" if t_end < scenario.duration_s - 1e-6 else
                 f"the run lasts {t_end:g} s")
        raise SpecError(
            f"scenario {scenario.name}, agent {agent}: metrics.line_tracking.transient_s is "
            f"{spec.transient_s:g} s but {ended} (duration_s {scenario.duration_s:g} s), so "
            "no sample is left to score after the transient; lower "
            "metrics.line_tracking.transient_s or raise duration_s")
    tr = sensor_track(scenario, agent, odom)
    course = line_parts(scenario, agent)[0].course
    length = course.length_m()
    t, off, prog = tr["t"].to_numpy(), tr["offset"].to_numpy(), tr["progress"].to_numpy()
    on_course = np.ones_like(t, bool) if course.closed else prog <= length

    lost_idx = np.flatnonzero((np.abs(off) > spec.lost_threshold_m) & on_course)
    lost = lost_idx.size > 0
    end = lost_idx[0] if lost else len(t)
    covered = float(np.max(prog[:end]) - prog[0]) if end > 0 else 0.0
    # a straight is covered from where the robot starts; a circle is one lap from anywhere
    todo = length if course.closed else length - prog[0]
    completion = min(1.0, max(0.0, covered / max(todo, 1e-9)))

    window = (t >= spec.transient_s) & on_course
    if lost:
        window &= t < t[end]
    err = off[window]
    rms = math.sqrt(float(np.mean(err**2))) if err.size else math.nan
    mx = float(np.max(np.abs(err))) if err.size else math.nan

    outside = np.flatnonzero((np.abs(off) > spec.settle_band_m) & on_course)
    settle = float(t[outside[-1] + 1]) if outside.size and outside[-1] + 1 < len(t) else (
        math.nan if outside.size else float(t[0]))

    lost_extra = {"time_s": round(float(t[end]), 6)} if lost else {}
    return [
        _m("cross_track_rms_m", rms),
        _m("cross_track_max_m", mx),
        _m("line_lost", 1.0 if lost else 0.0, **lost_extra),
        _m("completion", completion),
        _m("mean_speed_mps", float(np.mean(tr["vx"]))),
        _m("settle_time_s", settle),
    ]


def _line(ctx: ScoreContext, params: LineMetricsParams) -> list[Metric]:
    return line_metrics(ctx.scenario, ctx.agent, ctx.odom, params)


LINE_TRACKING = MetricSet(
    "line_tracking",
    {n: DEFS[n] for n in ("cross_track_rms_m", "cross_track_max_m", "line_lost", "completion",
                          "mean_speed_mps", "settle_time_s")},
    _line, LineMetricsParams, ("line_tracker",),
    "distance of the line sensor from the line, line lost, completion, settling")
