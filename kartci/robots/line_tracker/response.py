"""The line tracker's response shape (source document 001 Sec. 7.1-7.3): overshoot of the
straight-line release, and the oscillation amplitude on a circle. Opt-in (`metrics: {line_response:
{}}`), so scenarios that do not ask keep their metrics unchanged."""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from kartci.core import Direction, Metric, MetricDef, MetricParams, MetricSet
from kartci.core.params import Duration_s, Size_m
from kartci.metrics import ScoreContext
from kartci.robots.line_tracker.metrics import sensor_track
from kartci.robots.line_tracker.params import line_parts

DEFS: dict[str, MetricDef] = {
    "overshoot_ratio": MetricDef("1", Direction.LOWER, 0.02, 0.10,
                                 "farthest swing past the final offset, as a fraction of the "
                                 "step from the release offset to it (0: no overshoot)"),
    "peak_time_s": MetricDef("s", Direction.EQUAL, 0.1, 0.10,
                             "time of that farthest crossing; NaN without one"),
    "oscillation_amplitude_m": MetricDef("m", Direction.LOWER, 0.0002, 0.10,
                                         "half the peak-to-peak sensor offset after the "
                                         "transient, while on the line"),
}


class LineResponseParams(MetricParams):
    """Where the oscillation amplitude starts being measured."""

    transient_s: Duration_s = Field(5.0, description="start-up transient left out of the "
                                    "oscillation amplitude, s")
    lost_threshold_m: Size_m = Field(0.021, description="farther than this the line is "
                                     "lost and the rest of the run is left out, m (Eq. 6.15)")


def _m(name: str, value: float) -> Metric:
    return Metric(name, float(value), DEFS[name].unit)


def response_metrics(ctx: ScoreContext, params: LineResponseParams) -> list[Metric]:
    """Overshoot ratio and its time (the step from the first sample's offset to the final one)
    and the oscillation
    amplitude after the transient, up to the line being lost or the end of a straight."""
    odom = ctx.odom
    if odom.empty:
        return []
    tr = sensor_track(ctx.scenario, ctx.agent, odom)
    course = line_parts(ctx.scenario, ctx.agent)[0].course
    t, off = tr["t"].to_numpy(), tr["offset"].to_numpy()
    keep = np.ones_like(t, bool)
    if not course.closed:
        keep &= tr["progress"].to_numpy() <= course.length_m()
    lost = np.flatnonzero(np.abs(off) > params.lost_threshold_m)
    if lost.size:
        keep[lost[0]:] = False
    t, off = t[keep], off[keep]
    # the step is from the release offset to where the robot ends up (the sensor model's bias
    # leaves it a fraction of a millimetre off the axis): the median of the last quarter
    final = float(np.median(off[3 * off.size // 4:])) if off.size else 0.0
    d0 = float(off[0]) - final if off.size else 0.0
    crossing = -math.copysign(1.0, d0) * (off - final) if d0 != 0.0 else np.zeros_like(off)
    k = int(np.argmax(crossing)) if crossing.size else 0
    peak = float(crossing[k]) if crossing.size else 0.0
    ratio = max(peak, 0.0) / abs(d0) if d0 != 0.0 else math.nan
    late = off[t >= params.transient_s]
    amp = 0.5 * float(late.max() - late.min()) if late.size else math.nan
    return [_m("overshoot_ratio", ratio),
            _m("peak_time_s", float(t[k]) if peak > 0.0 else math.nan),
            _m("oscillation_amplitude_m", amp)]


LINE_RESPONSE = MetricSet("line_response", DEFS, response_metrics, LineResponseParams,
                          ("line_tracker",), "overshoot of a release, oscillation amplitude")
