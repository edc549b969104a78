"""The line lab's courses: a straight line or a closed circle, each with its own geometry.

Pure numpy, no simulator state: the line sensor (in the simulator) and the cross-track metrics
(from the course recorded in the log) ask the same course object. Offsets are signed, positive
to the left of the direction of travel (REP 103). Each course answers the questions of
`kartci.core.course.Course`; kind-neutral code asks those and never which shape it holds.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from numpy.typing import NDArray
from pydantic import Field, model_validator

from kartci.core.params import Angle_rad, Frozen
from kartci.scenario.models import Point_m

Array = NDArray[np.float64]


class StraightCourse(Frozen):
    """A straight black line from `start_m` to `end_m`; robots are done past its end."""

    type: Literal["straight"] = Field("straight", description="course shape: a straight line")
    start_m: Point_m = Field((0.0, 0.0), description="start of the line's axis, (x, y) in m, "
                             "world frame; the robot drives from here")
    end_m: Point_m = Field((2.5, 0.0), description="end of the line's axis, (x, y) in m, world "
                           "frame (the seed's straight test line)")

    @model_validator(mode="after")
    def _has_length(self) -> StraightCourse:
        if (self.end_m[0] - self.start_m[0]) ** 2 + (self.end_m[1] - self.start_m[1]) ** 2 < 1e-4:
            raise ValueError("end_m must be at least 0.01 m from start_m")
        return self

    @property
    def closed(self) -> bool:
        """A straight line has an end: robots are done past it."""
        return False

    def length_m(self) -> float:
        """Length of the line, m."""
        return float(np.hypot(*np.subtract(self.end_m, self.start_m)))

    def start_pose(self) -> tuple[float, float, float]:
        """Start point on the line axis and the heading of travel there (x m, y m, yaw rad)."""
        d = np.subtract(self.end_m, self.start_m)
        return self.start_m[0], self.start_m[1], float(np.arctan2(d[1], d[0]))

    def pose_at(self, along_m: float, lateral_m: float) -> tuple[float, float, float]:
        """A point `along_m` down the line and `lateral_m` left of it, with the heading there."""
        x0, y0, yaw = self.start_pose()
        c, s = np.cos(yaw), np.sin(yaw)
        return x0 + c * along_m - s * lateral_m, y0 + s * along_m + c * lateral_m, yaw

    def _axis(self) -> tuple[Array, Array]:
        """The line's start and unit direction."""
        d = np.subtract(self.end_m, self.start_m)
        return np.asarray(self.start_m), d / np.linalg.norm(d)

    def _frame(self, xy: Array) -> tuple[Array, Array]:
        start, u = self._axis()
        rel = xy - start
        along = rel @ u
        lateral = rel[..., 1] * u[0] - rel[..., 0] * u[1]
        return along, lateral

    def offset_m(self, xy: Array) -> Array:
        """Signed distance of points (..., 2) from the line axis, left of travel positive."""
        return self._frame(np.asarray(xy, dtype=float))[1]

    def progress_m(self, xy: Array) -> Array:
        """Distance along the line of each point (..., 2), m (negative before its start)."""
        return self._frame(np.asarray(xy, dtype=float))[0]

    def ink_coverage(self, width_m: float, x: Array, y: Array, pixel_m: float) -> Array:
        """Fraction (0-1) of a square pixel of side `pixel_m` centred at each point (x, y) that
        is black (see `CircleCourse.ink_coverage`); the line's ends are ramped too.

        offset_m's and progress_m's arithmetic on x and y apart, in place: the line sensor calls
        this for every image, and numpy's calls cost more than their arithmetic at its 512
        points."""
        (x0, y0), (u0, u1) = (v.tolist() for v in self._axis())
        rx, ry = x - x0, y - y0
        ink: Array = ry * u0 - rx * u1  # offset_m
        along: Array = rx * u0
        along += ry * u1  # progress_m: the sum `rel @ u` makes
        _band(ink, width_m, pixel_m)
        # the ramps at the line's ends, skipped when 1 at every point: the ramp is monotonic
        # in `along` and a product with 1.0 the same bits (NaN, from min or max, is not skipped);
        # numpy scalars, not floats: a pose gone non-finite divides as the arrays do, without
        # raising, and the run ends on its non-finite state
        total = self.length_m()
        if not along.min() / pixel_m + 0.5 >= 1.0:
            ink *= _ramp(along.copy(), pixel_m)
        if not (total - along.max()) / pixel_m + 0.5 >= 1.0:
            ink *= _ramp(total - along, pixel_m)
        return ink

    def polyline(self, n: int = 400) -> Array:
        """The line axis's two end points, for drawing (`n` is for closed courses)."""
        return np.linspace(self.start_m, self.end_m, 2)

    def curvature_at(self, along_m: float) -> float:
        """A straight line does not turn."""
        return 0.0

    def room_m(self, along_m: float) -> tuple[float, float]:
        """The lab's floor is open on both sides (a robot loses the line, not the floor)."""
        return math.inf, math.inf


class CircleCourse(Frozen):
    """A closed circular black line, driven counter-clockwise from angle `start_rad`."""

    type: Literal["circle"] = Field("circle", description="course shape: a closed circle")
    center_m: Point_m = Field((0.0, 0.0), description="centre of the circle, (x, y) in m, world "
                              "frame")
    radius_m: float = Field(1.0, gt=0.05, le=1e6, description="radius of the line's axis, m "
                            "(seed 001 Sec. 7.2 does not give it; line_lab/circle uses 0.362 m)")
    start_rad: Angle_rad = Field(-1.5707963267948966, description="polar angle of the start "
                                 "point about the centre, rad (-pi/2: the bottom of the circle, "
                                 "heading +x)")

    @property
    def closed(self) -> bool:
        """A circle never ends."""
        return True

    def length_m(self) -> float:
        """The circle's circumference, m."""
        return float(2.0 * np.pi * self.radius_m)

    def start_pose(self) -> tuple[float, float, float]:
        """Start point on the line axis and the heading of travel there (x m, y m, yaw rad)."""
        a = self.start_rad
        cx, cy = self.center_m
        r = self.radius_m
        return cx + r * np.cos(a), cy + r * np.sin(a), float(a + np.pi / 2)

    def pose_at(self, along_m: float, lateral_m: float) -> tuple[float, float, float]:
        """A point `along_m` round the circle and `lateral_m` left of it (inside), with the
        heading there."""
        a = self.start_rad + along_m / self.radius_m
        r = self.radius_m - lateral_m
        cx, cy = self.center_m
        return cx + r * np.cos(a), cy + r * np.sin(a), float(a + np.pi / 2)

    def offset_m(self, xy: Array) -> Array:
        """Signed distance of points (..., 2) from the line axis, inside (left) positive."""
        rel = np.asarray(xy, dtype=float) - np.asarray(self.center_m)
        out: Array = self.radius_m - np.hypot(rel[..., 0], rel[..., 1])
        return out

    def progress_m(self, xy: Array) -> Array:
        """Arc length of each point of a time-ordered track, unwrapped over laps, m."""
        rel = np.asarray(xy, dtype=float) - np.asarray(self.center_m)
        ang = np.unwrap(np.arctan2(rel[..., 1], rel[..., 0]) - self.start_rad)
        if ang.size:
            ang = ang - 2 * np.pi * np.round(ang[0] / (2 * np.pi))
        out: Array = ang * self.radius_m
        return out

    def ink_coverage(self, width_m: float, x: Array, y: Array, pixel_m: float) -> Array:
        """Fraction (0-1) of a square pixel of side `pixel_m` centred at each point (x, y) that
        is black.

        Edges are anti-aliased linearly, which is exact for an edge crossing a pixel parallel to
        a side and within a few percent otherwise; it keeps the geometric sensor smooth, like a
        rendered one. offset_m's arithmetic, in place (see `StraightCourse.ink_coverage`)."""
        ink: Array = np.hypot(x - self.center_m[0], y - self.center_m[1])
        np.subtract(self.radius_m, ink, out=ink)  # offset_m
        return _band(ink, width_m, pixel_m)

    def polyline(self, n: int = 400) -> Array:
        """`n` points along the line axis, for drawing, closed (the first point repeated)."""
        a = self.start_rad + np.linspace(0, 2 * np.pi, n)
        return np.column_stack([self.center_m[0] + self.radius_m * np.cos(a),
                                self.center_m[1] + self.radius_m * np.sin(a)])

    def curvature_at(self, along_m: float) -> float:
        """Driven counter-clockwise: a left turn of radius `radius_m` everywhere, 1/m."""
        return 1.0 / self.radius_m

    def room_m(self, along_m: float) -> tuple[float, float]:
        """The lab's floor is open on both sides (a robot loses the line, not the floor)."""
        return math.inf, math.inf


LineCourse = Annotated[StraightCourse | CircleCourse, Field(discriminator="type")]


def _band(offset: Array, width_m: float, pixel_m: float) -> Array:
    """In place: the coverage of a band `width_m` wide around the axis, from signed offsets."""
    np.abs(offset, out=offset)
    np.subtract(width_m / 2.0, offset, out=offset)
    return _ramp(offset, pixel_m)


def _ramp(x: Array, pixel_m: float) -> Array:
    """x / pixel_m + 0.5 clipped to 0-1, in place (np.clip's values without its wrapper)."""
    x /= pixel_m
    x += 0.5
    np.maximum(x, 0.0, out=x)
    out: Array = np.minimum(x, 1.0, out=x)
    return out
