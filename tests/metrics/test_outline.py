"""Outlines from a robot's description, and the distance between two of them: closed forms, and
PyBullet's own closest points between the kart's collision shapes (what collides is what
clearance measures)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import bullet_gaps_m

from kartci.errors import SpecError
from kartci.metrics.outline import (
    CIRCLE_SIDES,
    bounds,
    box,
    fixed,
    hull,
    outline_gap_m,
    placed,
    urdf_outline,
)
from kartci.robots.gokart import GokartModel
from kartci.robots.gokart.outline import footprint_m, half_width_m, outline

KART = outline(GokartModel())
REAR_REACH_M = 0.5625 + 0.127  # rear wheel centre (Table 3.2) plus the tyre radius (Table 3.1)
WHEEL_OVER_M = 0.127 * (1 / math.cos(math.pi / CIRCLE_SIDES) - 1)  # a wheel polygon's corners


def _gap(a: tuple[float, float, float], b: tuple[float, float, float]) -> float:
    return float(outline_gap_m(placed(KART, np.array([a])), placed(KART, np.array([b])))[0])


def test_the_karts_outline_is_its_urdfs_chassis_box_and_rear_wheels() -> None:
    """The chassis collision box (2.0 x 1.2 m centred 0.6 m ahead of base_link) and the rear
    wheel spheres, which stick out 0.09 m either side; the front wheels lie inside the box."""
    assert KART[0] == ((-0.4, -0.6), (1.6, -0.6), (1.6, 0.6), (-0.4, 0.6))
    assert [len(p) for p in KART] == [4, CIRCLE_SIDES, CIRCLE_SIDES]
    assert bounds(KART) == pytest.approx((0.6, 0.0, 2.0, 2 * REAR_REACH_M))
    assert half_width_m(GokartModel()) == pytest.approx(REAR_REACH_M)
    assert footprint_m(GokartModel()) == pytest.approx((0.6, 2.0, 2 * REAR_REACH_M))


@pytest.mark.parametrize(("b", "expected"), [
    ((0.0, 2.0, 0.0), 2.0 - 2 * REAR_REACH_M),  # side by side: rear wheel to rear wheel
    ((3.0, 0.0, 0.0), 1.0),  # nose to tail: 3 m apart, 2 m long
    ((4.0, 0.0, math.pi), 4.0 - 2 * 1.6),  # nose to nose
    ((0.0, 0.0, 0.3), 0.0),  # overlapping
    ((4.0, 3.0, 0.0), math.hypot(4.0 - 2.0, 3.0 - 1.2)),  # chassis corner to corner
])
def test_two_karts_gap_in_closed_form(b: tuple[float, float, float], expected: float) -> None:
    assert _gap((0.0, 0.0, 0.0), b) == pytest.approx(expected, abs=1e-9)
    # the same pair anywhere, turned any way: the distance is the pair's own
    c, s, yaw = math.cos(1.1), math.sin(1.1), 1.1
    moved = (5.0 + c * b[0] - s * b[1], -2.0 + s * b[0] + c * b[1], b[2] + yaw)
    assert _gap((5.0, -2.0, yaw), moved) == pytest.approx(expected, abs=1e-9)


def test_a_box_and_a_kart_and_many_poses_at_once() -> None:
    poses = np.array([[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [-5.0, 0.0, 0.0]])
    gap = outline_gap_m(placed(KART, poses), [fixed(box((3.6, 0.0), 2.0, 1.0, 0.0), 3)])
    assert gap == pytest.approx([1.0, 1.0, 6.0])
    assert hull(np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5], [1, 0]])) == (
        (0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0))


def test_outline_gaps_are_pybullets_closest_points_between_the_karts() -> None:
    """Two karts at random poses: the outline gap equals the distance PyBullet finds between
    their collision shapes (chassis boxes, wheel spheres), or less by at most what the polygons
    drawn round two wheels add."""
    rng = np.random.default_rng(3)
    a = np.column_stack([np.zeros(60), np.zeros(60), rng.uniform(-math.pi, math.pi, 60)])
    b = np.column_stack([rng.uniform(-3, 3, 60), rng.uniform(-3, 3, 60),
                         rng.uniform(-math.pi, math.pi, 60)])
    bullet = bullet_gaps_m(a, b)
    gaps = outline_gap_m(placed(KART, a), placed(KART, b))
    assert (bullet > 0).sum() > 30
    assert np.all(gaps <= bullet + 1e-6)
    assert np.all(gaps >= bullet - 2 * WHEEL_OVER_M - 1e-6)


def test_urdf_outline_follows_joints_and_refuses_meshes() -> None:
    urdf = """<robot name="r">
      <link name="base"><collision><origin xyz="1 0 0"/><geometry><box size="2 1 1"/></geometry>
        </collision></link>
      <link name="arm"><collision><origin xyz="1 0 0"/><geometry>
        <cylinder radius="0.1" length="1"/></geometry></collision></link>
      <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
        <origin xyz="2 0 0" rpy="0 0 1.5707963267948966"/></joint>
    </robot>"""
    parts = urdf_outline(urdf)
    assert len(parts) == 2
    # the arm turned 90 degrees about z at x = 2: its cylinder's centre at (2, 1)
    assert bounds(parts[1:]) == pytest.approx((2.0, 1.0, 0.2, 0.2), abs=1e-9)
    lying = urdf.replace('rpy="0 0 1.5707963267948966"', 'rpy="1.5707963267948966 0 0"')
    # turned 90 degrees about x: the cylinder's axis along y, seen from above a 0.2 x 1 m box
    assert bounds(urdf_outline(lying)[1:]) == pytest.approx((3.0, 0.0, 0.2, 1.0), abs=1e-3)
    with pytest.raises(SpecError, match="mesh collision shape has no outline"):
        urdf_outline(urdf.replace('<box size="2 1 1"/>', '<mesh filename="a.stl"/>'))
    with pytest.raises(SpecError, match="no collision shapes"):
        urdf_outline('<robot name="r"><link name="base"/></robot>')
