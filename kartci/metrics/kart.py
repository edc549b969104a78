"""Go-kart metrics from a run log: laps, collisions, time off track, speed, progress."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from kartci.core import Metric
from kartci.metrics.defs import DEFS
from kartci.robots.gokart.params import GokartModel
from kartci.spec.models import Scenario
from kartci.track import Track


def _m(name: str, value: float, **extra: object) -> Metric:
    return Metric(name, float(value), DEFS[name].unit, dict(extra))


def kart_track(track: Track, odom: pd.DataFrame) -> pd.DataFrame:
    """Time, position, speed, lateral offset and unwrapped progress (m) of base_link."""
    xy = odom[["x", "y"]].to_numpy()
    s, lateral, _, _ = track.project(xy)
    ds = np.diff(s)
    ds = (ds + track.length_m / 2) % track.length_m - track.length_m / 2
    start = s[0] - track.length_m if s[0] > track.length_m / 2 else s[0]
    total = start + np.concatenate([[0.0], np.cumsum(ds)])  # arc length from the line
    return pd.DataFrame({"t": odom["t"].to_numpy(), "x": xy[:, 0], "y": xy[:, 1],
                         "speed": np.hypot(odom["vx"], odom["vy"]), "offset": lateral,
                         "s_total": total, "yaw": odom["yaw"].to_numpy()})


def crossing_time(t: np.ndarray, total: np.ndarray, distance_m: float) -> float:
    """When the unwrapped progress `total` (m) first reached `distance_m` (it must), interpolated
    between samples: lap lines for the metrics, sector lines for the report's lap table."""
    i = int(np.argmax(total >= distance_m))
    a, b = total[i - 1], total[i]
    frac = (distance_m - a) / (b - a) if b != a else 0.0
    return float(t[i - 1] + frac * (t[i] - t[i - 1]))


def wheel_margins_m(track: Track, tr: pd.DataFrame, wheels_xy_m: np.ndarray) -> np.ndarray:
    """Per `kart_track` row, how far inside the track the wheel nearest an edge is (m; negative
    when it is outside), the quantity behind `off_track_s`."""
    yaw, x, y = tr["yaw"].to_numpy(), tr["x"].to_numpy(), tr["y"].to_numpy()
    margin = np.full(len(tr), np.inf)
    for wx, wy in wheels_xy_m:
        px = x + wx * np.cos(yaw) - wy * np.sin(yaw)
        py = y + wx * np.sin(yaw) + wy * np.cos(yaw)
        _, lat, w_right, w_left = track.project(np.column_stack([px, py]))
        margin = np.minimum(margin, np.minimum(w_left - lat, lat + w_right))
    return margin


def lap_crossings(t: np.ndarray, total: np.ndarray, length_m: float) -> list[float]:
    """Times (s) at which the unwrapped progress `total` (m) passes each whole lap."""
    return [crossing_time(t, total, lap * length_m)
            for lap in range(1, int(max(total.max(), 0) // length_m) + 1)]


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
