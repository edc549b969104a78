"""Hall geometry as boxes: walls, pillars and obstacles, shared by PyBullet and the fast lidar."""

from __future__ import annotations

from dataclasses import dataclass

from kartci.spec.models import HallWorld


@dataclass(frozen=True)
class Block:
    """A vertical box standing on the floor: centre (m), size (m), yaw (rad)."""

    name: str
    center: tuple[float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0


def blocks(spec: HallWorld) -> list[Block]:
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
