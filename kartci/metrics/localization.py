"""Localization errors from the log: the estimate (`localization/odom`) against ground truth
(`odom`), associated by stamp and compared without alignment (both are in the map frame) unless
`align` says otherwise (an imported log's estimate in another frame: `kartci.metrics.alignment`),
with
evo's APE / RPE conventions (`kartci.metrics.trajectory`), plus how the estimate converged from
its initial guess and how often and how long it diverged."""

from __future__ import annotations

from typing import Any

import numpy as np
from pydantic import Field

from kartci.core import Direction, Metric, MetricDef, MetricParams
from kartci.core.params import Duration_s, Period_s, Size_m
from kartci.errors import LogError
from kartci.metrics import ScoreContext
from kartci.metrics.alignment import Alignment, align
from kartci.metrics.trajectory import (
    DeltaUnit,
    Relation,
    Trajectory,
    TrajectoryError,
    ape_errors,
    associate,
    rpe,
)


class LocalizationMetricsParams(MetricParams):
    """Which topics to compare and the thresholds of convergence and divergence."""

    topic: str = Field("localization/odom", description="the estimate (nav_msgs/Odometry), "
                       "relative to the agent's namespace or absolute")
    reference_topic: str = Field("odom", description="ground truth (nav_msgs/Odometry)")
    max_diff_s: Period_s = Field(0.01, description="association: largest stamp "
                                 "difference of a pose pair, s (evo's --t_max_diff)")
    converged_m: Size_m = Field(0.1, description="the estimate has converged once its "
                                "position error stays below this for `hold_s`, m")
    hold_s: Duration_s = Field(1.0, description="how long the error must stay below "
                               "`converged_m`, s")
    diverged_m: Size_m = Field(0.3, description="after convergence, a position error "
                               "above this is a divergence event, m")
    rearm_s: Duration_s = Field(0.1, description="a dip below `diverged_m` shorter than "
                                "this does not end a divergence event (noise around the "
                                "threshold is one event, not two; 0.1 s: one 10 Hz lidar "
                                "correction), s")
    # left out of dumps at their defaults: existing scenarios keep their baseline hashes
    align: Alignment = Field(Alignment.NONE, exclude_if=lambda v: v is Alignment.NONE,
                             description="the estimate moved onto the reference first: none, "
                             "se3 / sim3 (Umeyama least squares; evo -a / -as) or origin "
                             "(first poses equal; evo --align_origin)")
    align_first: int | None = Field(None, ge=2, le=10**9, exclude_if=lambda v: v is None,
                                    description="se3 / sim3 fitted on the first N pose pairs "
                                    "only (evo --n_to_align); none: all")


DEFS: dict[str, MetricDef] = {
    "ape_rmse_m": MetricDef("m", Direction.LOWER, 0.002, 0.2, "APE translation RMSE of the "
                            "localization estimate (evo_ape; aligned as `align` says)"),
    "ape_mean_m": MetricDef("m", Direction.LOWER, 0.002, 0.2, "APE translation mean"),
    "ape_max_m": MetricDef("m", Direction.LOWER, 0.005, 0.2, "APE translation max"),
    "ape_rot_rmse_deg": MetricDef("deg", Direction.LOWER, 0.05, 0.2, "APE rotation RMSE "
                                  "(angle of R_est^-1 R_ref)"),
    "rpe_1m_rmse_m": MetricDef("m", Direction.LOWER, 0.002, 0.2, "RPE translation RMSE per "
                               "1 m of travelled path (evo_rpe -d 1 -u m)"),
    "rpe_1s_rmse_m": MetricDef("m", Direction.LOWER, 0.002, 0.2, "RPE translation RMSE per "
                               "1 s"),
    "converge_time_s": MetricDef("s", Direction.LOWER, 0.1, 0.2, "time from the first "
                                 "estimate until its error stays below the convergence "
                                 "threshold (inf: never)"),
    "divergence_events": MetricDef("count", Direction.LOWER, 0.0, 0.0, "times the error rose "
                                   "above the divergence threshold after convergence (a dip "
                                   "below it shorter than rearm_s, s, does not count again)"),
    "diverged_s": MetricDef("s", Direction.LOWER, 0.1, 0.2, "time spent above the "
                            "divergence threshold after convergence"),
    "recovery_s": MetricDef("s", Direction.LOWER, 0.1, 0.2, "longest divergence event, from "
                            "the crossing up to the crossing back (to the end: not recovered)"),
}


def _trajectory(ctx: ScoreContext, topic: str) -> Trajectory:
    table = ctx.table(topic)
    if table is None or table.empty:
        raise LogError(f"{ctx.path}: no {topic} messages of agent {ctx.agent}: is its "
                       "localization node running?")
    return Trajectory.from_odometry(table)


def localization_metrics(ctx: ScoreContext, params: LocalizationMetricsParams) -> list[Metric]:
    """APE, RPE, convergence and divergence of one agent's localization (none for an agent
    that runs no localization node and publishes no estimate)."""
    table = ctx.table(params.topic)
    if (table is None or table.empty) and "localization" not in ctx.scenario.agents[
            ctx.agent].nodes:
        return []
    ref, est = associate(_trajectory(ctx, params.reference_topic),
                         _trajectory(ctx, params.topic), params.max_diff_s)
    est, _ = align(ref, est, params.align, params.align_first)
    err = ape_errors(ref, est)
    rot = ape_errors(ref, est, Relation.ROTATION_DEG)
    out = [Metric("ape_rmse_m", float(np.sqrt(np.mean(err**2))), "m"),
           Metric("ape_mean_m", float(np.mean(err)), "m"),
           Metric("ape_max_m", float(np.max(err)), "m"),
           Metric("ape_rot_rmse_deg", float(np.sqrt(np.mean(rot**2))), "deg")]
    for name, delta, unit in (("rpe_1m_rmse_m", 1.0, DeltaUnit.METERS),
                              ("rpe_1s_rmse_m", 1.0, DeltaUnit.SECONDS)):
        try:
            value = rpe(ref, est, delta, unit).rmse
        except TrajectoryError:  # too short a run for one pair: no number, not a crash
            value = float("nan")
        out.append(Metric(name, value, "m"))
    return out + episodes(est.t_s, err, params)


def converge_index(t_s: np.ndarray, err: np.ndarray,
                   params: LocalizationMetricsParams) -> int | None:
    """The first pose from which the error stays below `converged_m` for `hold_s`; None when
    it never does."""
    start = None
    for i in range(len(t_s)):
        if err[i] >= params.converged_m:
            start = None
            continue
        start = i if start is None else start
        if t_s[i] - t_s[start] >= params.hold_s:
            return start
    return None


def spans(t_s: np.ndarray, above: np.ndarray, rearm_s: float) -> list[tuple[int, int | None]]:
    """The divergence events as (up, down) indices into `t_s` of the crossing up and the
    crossing back (None: not recovered); `above[i]` says the error at `t_s[i]` is above the
    threshold. A dip below it shorter than `rearm_s` (s) joins the events on either side."""
    step = np.diff(np.concatenate([[0], above.astype(int)]))
    downs = np.flatnonzero(step == -1)
    out: list[tuple[int, int | None]] = []
    for up in np.flatnonzero(step == 1):
        later = downs[downs > up]
        down = int(later[0]) if len(later) else None
        last = out[-1][1] if out else None
        if last is not None and t_s[up] - t_s[last] < rearm_s:
            out[-1] = (out[-1][0], down)
        else:
            out.append((int(up), down))
    return out


def episodes(t_s: np.ndarray, err: np.ndarray, params: LocalizationMetricsParams) -> list[Metric]:
    """Convergence time, then the divergence events after it (from the start when the
    estimate never converged: a lost estimate is one long divergence, not none)."""
    start = converge_index(t_s, err, params)
    converge = float("inf") if start is None else float(t_s[start] - t_s[0])
    t = t_s[start or 0:]
    above = err[start or 0:] > params.diverged_m
    longest, events = 0.0, []
    for up, down in spans(t, above, params.rearm_s):
        end = float(t[-1] if down is None else t[down])
        longest = max(longest, end - float(t[up]))
        events.append({"t_s": round(float(t[up]), 3),
                       "recovered_s": None if down is None else round(end - float(t[up]), 3)})
    dt = np.diff(t, append=t[-1])
    extra: dict[str, Any] = {"events": events}
    return [Metric("converge_time_s", converge, "s"),
            Metric("divergence_events", float(len(events)), "count", extra),
            Metric("diverged_s", float(np.sum(dt[above])), "s"),
            Metric("recovery_s", longest, "s")]
