"""What every world kind may hold: static boxes on the floor."""

from __future__ import annotations

from pydantic import Field

from kartci.core.params import Angle_rad, Frozen, Size_m
from kartci.scenario.models import Point_m


class Box(Frozen):
    """A static box obstacle standing on the floor."""

    center_m: Point_m = Field(description="centre of the box's footprint, (x, y) "
                                          "in m, world frame")
    size_m: tuple[Size_m, Size_m, Size_m] = Field((0.1, 0.1, 0.1), description="edge lengths "
                                               "(x, y, z) in m, before the yaw rotation")
    yaw_rad: Angle_rad = Field(0.0, description="rotation about the vertical axis, rad, "
                               "counter-clockwise")
