"""The indoor hall: walls, pillars and obstacles as boxes (shared by PyBullet and the fast
lidar), a ceiling, floor zones, and a closed track inside."""

from __future__ import annotations

import math

import numpy as np

from kartci._bullet import pb
from kartci.core import WorldParams
from kartci.errors import SpecError
from kartci.sim.blocks import Block
from kartci.worlds.hall.params import HallWorld
from kartci.worlds.track.world import TrackWorld


def blocks(spec: HallWorld) -> list[Block]:
    """The hall's static boxes: the four walls, then the pillars, then the obstacles (the track
    check relies on this order)."""
    sx, sy = spec.size_m
    t, h = spec.wall_thickness_m, spec.wall_height_m
    out = [
        Block("wall_south", (sx / 2, -t / 2), (sx + 2 * t, t, h)),
        Block("wall_north", (sx / 2, sy + t / 2), (sx + 2 * t, t, h)),
        Block("wall_west", (-t / 2, sy / 2), (t, sy, h)),
        Block("wall_east", (sx + t / 2, sy / 2), (t, sy, h)),
    ]
    p = spec.pillar_size_m
    out += [Block(f"pillar_{i}", (x, y), (p, p, h)) for i, (x, y) in enumerate(spec.pillars_m)]
    out += [Block(f"obstacle_{i}", b.center_m, b.size_m, b.yaw_rad)
            for i, b in enumerate(spec.obstacles)]
    return out


class Hall(TrackWorld):
    """An indoor hall: floor, walls, pillars, obstacles, a ceiling, and a closed track that
    must stay clear of the walls and pillars."""

    spec: HallWorld

    def __init__(self, spec: WorldParams, dt_s: float) -> None:
        assert isinstance(spec, HallWorld)
        super().__init__(spec, dt_s, blocks(spec), spec.wall_height_m)
        try:
            self._refuse_track_through(self.blocks[:4 + len(spec.pillars_m)])
        except SpecError:
            self.close()
            raise

    def build(self) -> int:
        """Floor, walls, pillars and obstacles, and a ceiling on the walls."""
        spec = self.spec
        floor = self._floor(np.zeros(2), np.asarray(spec.size_m), 1.0)
        for blk in self.blocks:
            self.names[self._box(blk.center, blk.size, blk.yaw)] = blk.name
        sx, sy = spec.size_m
        ceiling = self._box((sx / 2, sy / 2), (sx, sy, 0.1), 0.0)
        pb.resetBasePositionAndOrientation(ceiling, [sx / 2, sy / 2, spec.wall_height_m + 0.05],
                                           [0, 0, 0, 1], physicsClientId=self.client)
        self.names[ceiling] = "ceiling"
        return floor

    def _refuse_track_through(self, solid: list[Block]) -> None:
        """A track whose edges run through a wall or pillar cannot be driven: say so, once."""
        edges = np.vstack([self.track.xy, *self.track.bounds()])
        for blk in solid:
            c, s = math.cos(-blk.yaw), math.sin(-blk.yaw)
            rel = (edges - np.asarray(blk.center)) @ np.array([[c, s], [-s, c]])
            inside = np.all(np.abs(rel) < np.asarray(blk.size[:2]) / 2, axis=1)
            if inside.any():
                x, y = edges[int(np.argmax(inside))]
                raise SpecError(f"track {self.track_file.name} runs through {blk.name} at "
                                f"({x:.1f}, {y:.1f}) m; for a circuit without the hall use "
                                f"`world: {{kind: circuit, track: ...}}`")
