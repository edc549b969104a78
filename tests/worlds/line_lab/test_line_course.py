"""The line lab's courses: offsets, progress, poses and ink, each shape its own."""

from __future__ import annotations

import numpy as np
import pytest

from kartci.core.course import Course
from kartci.worlds.line_lab import CircleCourse, StraightCourse


def test_straight_offset_and_progress() -> None:
    c = StraightCourse(start_m=(1.0, 1.0), end_m=(1.0, 3.0))  # heading +y
    pts = np.array([[0.99, 1.5], [1.02, 2.0]])
    assert c.offset_m(pts) == pytest.approx([0.01, -0.02])  # left of +y is -x
    assert c.progress_m(pts) == pytest.approx([0.5, 1.0])
    assert c.length_m() == 2.0


def test_circle_offset_and_unwrapped_progress() -> None:
    c = CircleCourse(center_m=(0.0, 0.0), radius_m=0.5, start_rad=-np.pi / 2)
    a = np.linspace(-np.pi / 2, 3 * np.pi / 2 - 1e-3, 50)
    pts = np.column_stack([0.49 * np.cos(a), 0.49 * np.sin(a)])
    assert c.offset_m(pts) == pytest.approx(np.full(50, 0.01))  # inside = left (CCW)
    prog = c.progress_m(pts)
    assert prog[0] == pytest.approx(0.0, abs=1e-12)
    assert prog[-1] == pytest.approx(2 * np.pi * 0.5, rel=1e-3)


def test_pose_at_circle_is_tangent() -> None:
    c = CircleCourse(radius_m=1.0, start_rad=0.0)
    x, y, yaw = c.pose_at(np.pi / 2, 0.0)
    assert (x, y, yaw) == pytest.approx((0.0, 1.0, np.pi))


def test_ink_coverage_antialiases_edges() -> None:
    c = StraightCourse(start_m=(0.0, 0.0), end_m=(1.0, 0.0))
    pts = np.array([[0.5, 0.0], [0.5, 0.007], [0.5, 0.02]])
    cov = c.ink_coverage(0.014, pts[:, 0], pts[:, 1], pixel_m=0.002)
    assert cov == pytest.approx([1.0, 0.5, 0.0])


def test_both_shapes_answer_what_shared_code_asks_of_a_course() -> None:
    """Kind-neutral code asks `kartci.core.course.Course`; each shape answers it, and says
    itself whether robots finish past an end."""
    straight, circle = StraightCourse(), CircleCourse()
    assert isinstance(straight, Course) and isinstance(circle, Course)
    assert (straight.closed, circle.closed) == (False, True)
    assert straight.polyline().shape == (2, 2)
    ring = circle.polyline(50)
    assert ring.shape == (50, 2) and ring[0] == pytest.approx(ring[-1])
    assert straight.pose_at(0.0, 0.0) == pytest.approx(straight.start_pose())


def test_the_lines_curve_and_leave_the_floor_open() -> None:
    """A straight does not turn; the circle, driven counter-clockwise, turns left at 1/r;
    the lab's floor has no edge (a robot loses the line, not the floor)."""
    straight, circle = StraightCourse(), CircleCourse(radius_m=0.4)
    assert (straight.curvature_at(1.0), circle.curvature_at(1.0)) == (0.0, 2.5)
    assert straight.room_m(0.5) == circle.room_m(0.5) == (np.inf, np.inf)
