"""How the kart drove, from its log: how far it slid (sideslip), how long it spun, how long a
tyre was at its grip, how long it made no progress. A lap can be fast and clean while the
kart drifts round it at 40 degrees; these say so.

Sideslip is the angle between base_link's heading and its direction of travel, both from the
odometry (twist in base_link: atan2(v_y, v_x)), measured only while base_link moves faster than
`moving_mps` (below it the direction of travel is noise). Times are samples x the median
sample period (as `off_track_s`), except the stalled time, which adds the odometry intervals
whose progress along the track was slower than `stall_mps`.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from pydantic import Field

from kartci.core import Direction, Metric, MetricDef, MetricParams


class HandlingParams(MetricParams):
    """Thresholds of the handling metrics (`metrics: {handling: {...}}`)."""

    moving_mps: float = Field(2.0, ge=0.0, le=100.0, description="sideslip is measured while "
                              "base_link is faster than this, m/s")
    spin_deg: float = Field(30.0, gt=0.0, le=180.0, description="sideslip above this is a "
                            "spin, deg")
    saturated: float = Field(0.95, gt=0.0, le=1.0, description="a tyre making at least this "
                             "fraction of its grip is saturated (dimensionless)")
    stall_mps: float = Field(0.1, ge=0.0, le=100.0, description="progress along the track "
                             "slower than this is stalled, m/s")


HANDLING_DEFS: dict[str, MetricDef] = {
    "max_sideslip_deg": MetricDef("deg", Direction.LOWER, 1.0, 0.1, "largest angle between "
                                  "base_link's heading and its direction of travel while "
                                  "faster than `moving_mps` (0 if never)"),
    "rms_sideslip_deg": MetricDef("deg", Direction.LOWER, 0.5, 0.1, "RMS of that angle over "
                                  "the same samples"),
    "spin_s": MetricDef("s", Direction.LOWER, 0.1, 0.1, "time faster than `moving_mps` with "
                        "the sideslip above `spin_deg`"),
    "tyre_saturated_s": MetricDef("s", Direction.LOWER, 0.1, 0.1, "time with any tyre making "
                                  "`saturated` of its grip or more (the `tyres` topic)"),
    "stalled_s": MetricDef("s", Direction.LOWER, 0.1, 0.1, "time whose progress along the "
                           "track was slower than `stall_mps` (backwards included)"),
}


def _period_s(t: np.ndarray) -> float:
    return float(np.median(np.diff(t))) if len(t) > 1 else 0.0


def sideslip_deg(odom: pd.DataFrame, moving_mps: float) -> np.ndarray:
    """|heading - direction of travel| of base_link, deg, at each odometry sample faster than
    `moving_mps`."""
    vx, vy = odom["vx"].to_numpy(dtype=float), odom["vy"].to_numpy(dtype=float)
    fast = np.hypot(vx, vy) > moving_mps
    out: np.ndarray = np.degrees(np.abs(np.arctan2(vy[fast], vx[fast])))
    return out


def saturated_s(tyres: pd.DataFrame, saturated: float) -> float:
    """Time with any tyre at `saturated` of its grip or more, s (a tyre without grip, on a
    floor without friction, is always at it)."""
    wheels = [c.removesuffix(".grip_n") for c in tyres.columns if c.endswith(".grip_n")]
    at_limit = np.zeros(len(tyres), dtype=bool)
    for w in wheels:
        force = np.hypot(tyres[f"{w}.fx_n"].to_numpy(dtype=float),
                         tyres[f"{w}.fy_n"].to_numpy(dtype=float))
        at_limit |= force >= saturated * tyres[f"{w}.grip_n"].to_numpy(dtype=float)
    return float(at_limit.sum()) * _period_s(tyres["t"].to_numpy())


def stalled_s(path: pd.DataFrame, stall_mps: float) -> float:
    """Sum of the intervals between odometry samples whose progress along the track
    (`kart_track`'s s_total) was slower than `stall_mps`, s."""
    dt = np.diff(path["t"].to_numpy(dtype=float))
    ds = np.diff(path["s_total"].to_numpy(dtype=float))
    return float(dt[ds < stall_mps * dt].sum())


def handling_metrics(odom: pd.DataFrame, path: pd.DataFrame, tyres: pd.DataFrame | None,
                     params: HandlingParams) -> list[Metric]:
    """Sideslip, spin time and stalled time from the odometry and the path along the track;
    tyre saturation where the log has the tyres' forces."""
    beta = sideslip_deg(odom, params.moving_mps)
    spin = float((beta > params.spin_deg).sum()) * _period_s(odom["t"].to_numpy())
    out = [Metric("max_sideslip_deg", float(beta.max()) if len(beta) else 0.0, "deg"),
           Metric("rms_sideslip_deg", math.sqrt(float(np.mean(beta**2))) if len(beta) else 0.0,
                  "deg"),
           Metric("spin_s", spin, "s")]
    if tyres is not None and not tyres.empty:
        out.append(Metric("tyre_saturated_s", saturated_s(tyres, params.saturated), "s"))
    out.append(Metric("stalled_s", stalled_s(path, params.stall_mps), "s"))
    return out
