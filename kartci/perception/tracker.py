"""Boxes tracked across scans: nearest-neighbour association within a gate, an alpha-beta
filter per track for position and velocity. A track is dynamic once it is both fast (filtered
speed) and far from where it was first seen: the centre of a box seen from a passing kart
wanders by a few decimetres as other faces come into view, which the speed alone takes for
motion."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from kartci.perception.clusters import Box

ALPHA, BETA = 0.5, 0.2  # alpha-beta gains: smooth positions, velocities from a few scans


@dataclass
class Track:
    """One obstacle over time."""

    id: int
    box: Box
    t_s: float
    xy: np.ndarray
    v: np.ndarray = field(default_factory=lambda: np.zeros(2))
    hits: int = 1
    moved: bool = False  # ever fast and far from its first position
    origin: np.ndarray = field(default_factory=lambda: np.zeros(2))

    @property
    def speed_mps(self) -> float:
        """Filtered speed, m/s."""
        return float(np.hypot(*self.v))


class Tracker:
    """Tracks by id; `update` takes one scan's boxes."""

    def __init__(self, gate_m: float, dynamic_mps: float, dynamic_m: float) -> None:
        """No tracks yet."""
        self.gate_m, self.dynamic_mps, self.dynamic_m = gate_m, dynamic_mps, dynamic_m
        self.tracks: list[Track] = []
        self.next_id = 0

    def update(self, t_s: float, boxes: list[Box]) -> None:
        """Associate greedily by distance to each track's prediction, then filter."""
        pred = [tr.xy + tr.v * (t_s - tr.t_s) if tr.moved else tr.xy for tr in self.tracks]
        pairs = sorted((float(np.hypot(*(p - (b.x, b.y)))), i, j)
                       for i, p in enumerate(pred) for j, b in enumerate(boxes))
        used_t: set[int] = set()
        used_b: set[int] = set()
        for d, i, j in pairs:
            if d > self.gate_m or i in used_t or j in used_b:
                continue
            used_t.add(i)
            used_b.add(j)
            self._correct(self.tracks[i], pred[i], boxes[j], t_s)
        for j, b in enumerate(boxes):
            if j not in used_b:
                xy = np.array([b.x, b.y])
                self.tracks.append(Track(self.next_id, b, t_s, xy, origin=xy.copy()))
                self.next_id += 1

    def _correct(self, tr: Track, pred: np.ndarray, b: Box, t_s: float) -> None:
        dt = t_s - tr.t_s
        r = np.array([b.x, b.y]) - pred
        tr.xy = pred + ALPHA * r
        if dt > 0:
            tr.v = tr.v + BETA * r / dt
        tr.box, tr.t_s, tr.hits = b, t_s, tr.hits + 1
        tr.moved = tr.moved or (tr.speed_mps > self.dynamic_mps and float(
            np.hypot(*(tr.xy - tr.origin))) > self.dynamic_m)

    def prune(self, t_s: float, keep_static_s: float, keep_dynamic_s: float,
              established_hits: int = 1) -> None:
        """Drop tracks unseen for too long: dynamic ones and static ones seen in fewer than
        `established_hits` scans sooner."""
        self.tracks = [tr for tr in self.tracks if t_s - tr.t_s <= (
            keep_dynamic_s if tr.moved or tr.hits < established_hits else keep_static_s)]

    def heading(self, tr: Track) -> float:
        """A moving track's heading is its velocity's; a static one's its box's."""
        return math.atan2(tr.v[1], tr.v[0]) if tr.moved else tr.box.yaw
