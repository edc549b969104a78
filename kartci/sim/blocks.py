"""Static geometry as vertical boxes, shared by PyBullet bodies and the fast lidar."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Block:
    """A vertical box standing on the floor: centre (m), size (m), yaw (rad)."""

    name: str
    center: tuple[float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0
