"""Course geometry shared by the simulator (line sensor) and the metrics (cross-track error).

Pure numpy, no simulator state: the metrics recompute everything from the course recorded in the
log. Offsets are signed, positive to the left of the direction of travel (REP 103).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from kartci.scenario.models import CircleCourse, StraightCourse

Course = StraightCourse | CircleCourse
Array = NDArray[np.float64]


def length_m(course: Course) -> float:
    """Length of the course, m (a circle's circumference)."""
    if isinstance(course, StraightCourse):
        return float(np.hypot(*np.subtract(course.end_m, course.start_m)))
    return float(2.0 * np.pi * course.radius_m)


def start_pose(course: Course) -> tuple[float, float, float]:
    """Start point on the line axis and the heading of travel there (x m, y m, yaw rad)."""
    if isinstance(course, StraightCourse):
        d = np.subtract(course.end_m, course.start_m)
        return course.start_m[0], course.start_m[1], float(np.arctan2(d[1], d[0]))
    a = course.start_rad
    cx, cy = course.center_m
    r = course.radius_m
    return cx + r * np.cos(a), cy + r * np.sin(a), float(a + np.pi / 2)


def pose_at(course: Course, along_m: float, lateral_m: float) -> tuple[float, float, float]:
    """A point `along_m` down the course and `lateral_m` left of it, with the heading there."""
    if isinstance(course, StraightCourse):
        x0, y0, yaw = start_pose(course)
        c, s = np.cos(yaw), np.sin(yaw)
        return x0 + c * along_m - s * lateral_m, y0 + s * along_m + c * lateral_m, yaw
    a = course.start_rad + along_m / course.radius_m
    r = course.radius_m - lateral_m
    cx, cy = course.center_m
    return cx + r * np.cos(a), cy + r * np.sin(a), float(a + np.pi / 2)


def _axis(course: StraightCourse) -> tuple[Array, Array]:
    """The line's start and unit direction."""
    d = np.subtract(course.end_m, course.start_m)
    return np.asarray(course.start_m), d / np.linalg.norm(d)


def _straight_frame(course: StraightCourse, xy: Array) -> tuple[Array, Array]:
    start, u = _axis(course)
    rel = xy - start
    along = rel @ u
    lateral = rel[..., 1] * u[0] - rel[..., 0] * u[1]
    return along, lateral


def offset_m(course: Course, xy: Array) -> Array:
    """Signed distance of points (..., 2) from the line axis, left of travel positive."""
    xy = np.asarray(xy, dtype=float)
    if isinstance(course, StraightCourse):
        return _straight_frame(course, xy)[1]
    rel = xy - np.asarray(course.center_m)
    out: Array = course.radius_m - np.hypot(rel[..., 0], rel[..., 1])
    return out


def progress_m(course: Course, xy: Array) -> Array:
    """Arc length along the course of each point of a time-ordered track (circle: unwrapped)."""
    xy = np.asarray(xy, dtype=float)
    if isinstance(course, StraightCourse):
        return _straight_frame(course, xy)[0]
    rel = xy - np.asarray(course.center_m)
    ang = np.unwrap(np.arctan2(rel[..., 1], rel[..., 0]) - course.start_rad)
    if ang.size:
        ang = ang - 2 * np.pi * np.round(ang[0] / (2 * np.pi))
    out: Array = ang * course.radius_m
    return out


def ink_coverage(course: Course, width_m: float, x: Array, y: Array, pixel_m: float) -> Array:
    """Fraction (0-1) of a square pixel of side `pixel_m` centred at each point (x, y) that is
    black.

    Edges are anti-aliased linearly, which is exact for an edge crossing a pixel parallel to a side
    and within a few percent otherwise; it keeps the geometric sensor smooth, like a rendered one.
    offset_m's and progress_m's arithmetic on x and y apart, in place: the line sensor calls this
    for every image, and numpy's calls cost more than their arithmetic at its 512 points.
    """
    if isinstance(course, StraightCourse):
        (x0, y0), (u0, u1) = (v.tolist() for v in _axis(course))
        rx, ry = x - x0, y - y0
        ink: Array = ry * u0 - rx * u1  # offset_m
        along: Array = rx * u0
        along += ry * u1  # progress_m: the sum `rel @ u` makes
    else:
        ink = np.hypot(x - course.center_m[0], y - course.center_m[1])
        np.subtract(course.radius_m, ink, out=ink)  # offset_m
    np.abs(ink, out=ink)
    np.subtract(width_m / 2.0, ink, out=ink)
    _ramp(ink, pixel_m)
    if isinstance(course, StraightCourse):
        # the ramps at the line's ends, skipped when 1 at every point: the ramp is monotonic
        # in `along` and a product with 1.0 the same bits (NaN, from min or max, is not skipped);
        # numpy scalars, not floats: a pose gone non-finite divides as the arrays do, without
        # raising, and the run ends on its non-finite state
        total = length_m(course)
        if not along.min() / pixel_m + 0.5 >= 1.0:
            ink *= _ramp(along.copy(), pixel_m)
        if not (total - along.max()) / pixel_m + 0.5 >= 1.0:
            ink *= _ramp(total - along, pixel_m)
    return ink


def _ramp(x: Array, pixel_m: float) -> Array:
    """x / pixel_m + 0.5 clipped to 0-1, in place (np.clip's values without its wrapper)."""
    x /= pixel_m
    x += 0.5
    np.maximum(x, 0.0, out=x)
    out: Array = np.minimum(x, 1.0, out=x)
    return out


def polyline(course: Course, n: int = 400) -> Array:
    """Points along the line axis, for drawing (closed for a circle)."""
    if isinstance(course, StraightCourse):
        return np.linspace(course.start_m, course.end_m, 2)
    a = course.start_rad + np.linspace(0, 2 * np.pi, n)
    return np.column_stack([course.center_m[0] + course.radius_m * np.cos(a),
                            course.center_m[1] + course.radius_m * np.sin(a)])
