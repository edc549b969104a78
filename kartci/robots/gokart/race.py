"""Racing metrics from a run log: clearance to obstacles and other karts, overtakes, and the
MPCC's solver statistics."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from kartci.core import Metric
from kartci.scenario.models import Box

Rect = np.ndarray  # (4, 2) corners, counter-clockwise


def rect(cx: float, cy: float, length: float, width: float, yaw: float) -> Rect:
    """Corners of a `length` x `width` rectangle (m) centred on (cx, cy), turned by `yaw` (rad)."""
    c, s = math.cos(yaw), math.sin(yaw)
    local = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
    out: Rect = local @ np.array([[c, s], [-s, c]]) + [cx, cy]
    return out


def kart_rects(odom: pd.DataFrame, footprint_m: tuple[float, float, float]) -> list[Rect]:
    """A robot's footprint (centre ahead of base_link, length, width; m) at each odometry row."""
    ahead, length, width = footprint_m
    return [rect(x + ahead * math.cos(yaw), y + ahead * math.sin(yaw), length, width, yaw)
            for x, y, yaw in odom[["x", "y", "yaw"]].to_numpy()]


def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(((p - a) @ ab) / (ab @ ab), 0.0, 1.0)
    out: np.ndarray = np.hypot(*(p - (a + t[:, None] * ab)).T)
    return out


def _overlap(a: Rect, b: Rect) -> bool:
    """Separating-axis test for two rectangles."""
    for poly in (a, b):
        for i in range(4):
            edge = poly[(i + 1) % 4] - poly[i]
            axis = np.array([-edge[1], edge[0]])
            pa, pb = a @ axis, b @ axis
            if pa.max() < pb.min() or pb.max() < pa.min():
                return False
    return True


def gap_m(a: Rect, b: Rect) -> float:
    """Distance between two rectangles (0 when they touch or overlap)."""
    if _overlap(a, b):
        return 0.0
    best = math.inf
    for p, q in ((a, b), (b, a)):
        for i in range(4):
            best = min(best, float(_point_segment(p, q[i], q[(i + 1) % 4]).min()))
    return best


def min_clearance_m(mine: list[Rect], obstacles: tuple[Box, ...],
                    others: list[list[Rect]]) -> float:
    """Smallest gap between this kart's footprint and any obstacle or other kart; nan when
    there is nothing to keep clear of."""
    boxes = [rect(b.center_m[0], b.center_m[1], b.size_m[0], b.size_m[1], b.yaw_rad)
             for b in obstacles]
    best = math.inf
    for i, me in enumerate(mine):
        for box in boxes:
            best = min(best, gap_m(me, box))
        for other in others:
            if i < len(other):
                best = min(best, gap_m(me, other[i]))
    return best if math.isfinite(best) else math.nan


def overtakes(mine: np.ndarray, others: list[np.ndarray]) -> int:
    """Net passes: times this kart's progress went from behind to ahead of another's, minus
    the times it was passed back (so side-by-side flicker cancels out)."""
    count = 0
    for other in others:
        n = min(len(mine), len(other))
        ahead = np.sign(mine[:n] - other[:n])
        ahead = ahead[ahead != 0]
        if len(ahead) < 2:
            continue
        changes = np.diff(ahead)
        count += int((changes > 0).sum()) - int((changes < 0).sum())
    return count


def solver_values(stats: pd.DataFrame) -> tuple[int, dict[str, float]]:
    """(failed solves, wall-clock solve-time statistics in ms)."""
    ms = stats["solve_ms"].to_numpy(dtype=float)
    failures = int((~stats["success"].astype(bool)).sum())
    return failures, {"solve_ms_median": float(np.median(ms)),
                      "solve_ms_p95": float(np.percentile(ms, 95)),
                      "solve_ms_max": float(ms.max())}


def race_metrics(scenario: Any, agent: str, paths: Mapping[str, pd.DataFrame],
                 rects: Mapping[str, list[Rect]], stats: pd.DataFrame | None) -> list[Metric]:
    """Clearance, overtakes and solver statistics, where the run has what they need. `rects`
    holds the robots that have a footprint: the others are not kept clear of."""
    obstacles = getattr(scenario.world, "obstacles", ())
    others = [n for n in paths if n != agent]
    out = []
    if obstacles or others:
        gap = min_clearance_m(rects[agent], obstacles, [rects[n] for n in others if n in rects])
        out.append(Metric("min_clearance_m", gap, "m"))
    if others:
        theirs = [paths[n]["s_total"].to_numpy() for n in others]
        out.append(Metric("overtakes", float(overtakes(paths[agent]["s_total"].to_numpy(),
                                                       theirs)), "count"))
    if stats is not None and not stats.empty:
        failures, timing = solver_values(stats)
        out.append(Metric("solver_failures", float(failures), "count"))
        out += [Metric(name, value, "ms") for name, value in timing.items()]
    return out
