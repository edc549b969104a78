"""A robot's path along a track, read from its odometry: progress, offset from the centreline,
lap and sector line crossings, wheel margins to the track's edges: what lap metrics and
plots of any robot kind read, and the metrics of an imported log that holds a track."""

from __future__ import annotations

import numpy as np
import pandas as pd

from kartci.worlds.track import Track


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
