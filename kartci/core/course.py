"""What kind-neutral code may ask of a world's course (a line on the floor, a track's
centreline) without knowing its shape: each world kind's course object answers these itself,
so no shared module branches on the shape."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

Array = NDArray[np.float64]


@runtime_checkable
class Course(Protocol):
    """A course robots follow: positions along it and beside it, in the world frame (m, rad;
    offsets left of the direction of travel positive, REP 103)."""

    @property
    def closed(self) -> bool:
        """True for a loop (no end); False for a course that robots finish past its end."""
        ...

    def length_m(self) -> float:
        """Length of the course (one lap of a loop), m."""
        ...

    def pose_at(self, along_m: float, lateral_m: float) -> tuple[float, float, float]:
        """x, y (m) of the point `along_m` down the course and `lateral_m` left of it, and the
        heading of travel there (rad)."""
        ...

    def offset_m(self, xy: Array) -> Array:
        """Signed distance of points (..., 2) from the course, m, left positive."""
        ...

    def progress_m(self, xy: Array) -> Array:
        """Distance along the course of each point of a time-ordered track (..., 2), m;
        unwrapped over laps of a loop."""
        ...

    def polyline(self, n: int = 400) -> Array:
        """Points (k, 2) along the course, for drawing; a loop closed, with at most `n`."""
        ...

    def curvature_at(self, along_m: float) -> float:
        """Curvature of the course `along_m` down it, 1/m, left turns positive."""
        ...

    def room_m(self, along_m: float) -> tuple[float, float]:
        """How far right and left of the course a robot may be `along_m` down it before it
        has left it, m (inf: an open floor)."""
        ...
