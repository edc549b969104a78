from __future__ import annotations

import numpy as np
import pytest

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
