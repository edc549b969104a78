"""A race circuit from a TUMFTM track alone: ground sized to the track and, optionally, barriers
along both edges (boxes following each edge at a set distance). Nothing else stands in the way,
so any real circuit can be driven without the indoor hall's walls."""

from __future__ import annotations

import math

import numpy as np

from kartci.core import WorldParams
from kartci.sim.blocks import Block
from kartci.worlds.circuit.params import CircuitWorld
from kartci.worlds.track.model import Track
from kartci.worlds.track.world import TrackWorld

NO_CEILING_M = 1000.0  # open sky: upward lidar beams find nothing in range


class Circuit(TrackWorld):
    """A TUMFTM track on open ground with optional barriers and obstacles; no walls, no ceiling."""

    spec: CircuitWorld

    def __init__(self, spec: WorldParams, dt_s: float) -> None:
        assert isinstance(spec, CircuitWorld)
        self.spec = spec  # barrier geometry needs the track, loaded by TrackWorld first
        super().__init__(spec, dt_s, [], NO_CEILING_M)

    def build(self) -> int:
        """Barriers (when asked for), obstacles, and a floor spanning the track plus `margin_m`."""
        spec, track = self.spec, self.track
        if spec.barriers:
            self.blocks = barrier_blocks(track, spec)
        self.blocks += [Block(f"obstacle_{i}", b.center_m, b.size_m, b.yaw_rad)
                        for i, b in enumerate(spec.obstacles)]
        left, right = track.bounds()
        pts = np.vstack([left, right])
        floor = self._floor(pts.min(axis=0) - spec.margin_m, pts.max(axis=0) + spec.margin_m,
                            1.0)
        for blk in self.blocks:
            self.names[self._box(blk.center, blk.size, blk.yaw)] = blk.name
        return floor


def barrier_blocks(track: Track, spec: CircuitWorld) -> list[Block]:
    """Boxes along both edges, each about `barrier_segment_m` long, their inner faces
    `barrier_offset_m` outside the track's edge."""
    normal = np.column_stack([-np.sin(track.heading), np.cos(track.heading)])
    out: list[Block] = []
    for side, sign, width in (("left", 1.0, track.w_left), ("right", -1.0, track.w_right)):
        away = width + spec.barrier_offset_m + spec.barrier_thickness_m / 2
        line = track.xy + sign * normal * away[:, None]
        out += _segments(line, spec, f"barrier_{side}")
    return out


def _segments(line: np.ndarray, spec: CircuitWorld, name: str) -> list[Block]:
    closed = np.vstack([line, line[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(closed, axis=0).T))])
    n = max(3, math.ceil(s[-1] / spec.barrier_segment_m))
    knots = np.column_stack([np.interp(np.linspace(0, s[-1], n + 1), s, closed[:, i])
                             for i in (0, 1)])
    blocks = []
    for i in range(n):
        a, b = knots[i], knots[i + 1]
        length = float(np.hypot(*(b - a))) + spec.barrier_thickness_m  # corners overlap
        mid = (a + b) / 2
        blocks.append(Block(f"{name}_{i}", (float(mid[0]), float(mid[1])),
                            (length, spec.barrier_thickness_m, spec.barrier_height_m),
                            math.atan2(float(b[1] - a[1]), float(b[0] - a[0]))))
    return blocks
