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


def _straight_frame(course: StraightCourse, xy: Array) -> tuple[Array, Array]:
    start = np.asarray(course.start_m)
    d = np.subtract(course.end_m, course.start_m)
    u = d / np.linalg.norm(d)
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


def ink_coverage(course: Course, width_m: float, xy: Array, pixel_m: float) -> Array:
    """Fraction (0-1) of a square pixel of side `pixel_m` centred at each point that is black.

    Edges are anti-aliased linearly, which is exact for an edge crossing a pixel parallel to a side
    and within a few percent otherwise; it keeps the geometric sensor smooth, like a rendered one.
    """
    half = width_m / 2.0
    inside = np.clip((half - np.abs(offset_m(course, xy))) / pixel_m + 0.5, 0.0, 1.0)
    if isinstance(course, StraightCourse):
        along = _straight_frame(course, np.asarray(xy, dtype=float))[0]
        total = length_m(course)
        inside = inside * np.clip(along / pixel_m + 0.5, 0, 1)
        inside = inside * np.clip((total - along) / pixel_m + 0.5, 0, 1)
    return inside


def polyline(course: Course, n: int = 400) -> Array:
    """Points along the line axis, for drawing (closed for a circle)."""
    if isinstance(course, StraightCourse):
        return np.linspace(course.start_m, course.end_m, 2)
    a = course.start_rad + np.linspace(0, 2 * np.pi, n)
    return np.column_stack([course.center_m[0] + course.radius_m * np.cos(a),
                            course.center_m[1] + course.radius_m * np.sin(a)])
