"""The kart seen from above, from its description: the URDF's collision shapes (chassis box and
wheel spheres, the geometry PyBullet collides) at zero joint angles, as convex parts in
base_link. One outline for clearance, detection ground truth, other karts' lidar and the
MPCC's padding: no second, hand-typed size."""

from __future__ import annotations

from kartci.core import Outline, RobotParams
from kartci.metrics.outline import bounds, urdf_outline
from kartci.sim.urdf import urdf_path, urdf_text


def outline(model: RobotParams, urdf: str | None = None) -> Outline:
    """The kart's outline in base_link, m. `urdf`: the description as a run log recorded it
    (`/<agent>/robot_description`); None: read from the model's URDF file."""
    return urdf_outline(urdf if urdf is not None else urdf_text(urdf_path(model)))


def half_width_m(model: RobotParams) -> float:
    """How far the outline reaches either side of the kart's centre line, m (the rear wheels:
    0.69 m on the shipped karts): the least track padding that keeps the kart on the track."""
    _, cy, _, width = bounds(outline(model))
    return abs(cy) + width / 2


def footprint_m(model: RobotParams) -> tuple[float, float, float]:
    """The outline's bounding box as (centre ahead of base_link, length, width), m."""
    cx, _, length, width = bounds(outline(model))
    return cx, length, width
