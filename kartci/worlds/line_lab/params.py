"""The line lab's parameters (`world: {kind: line_lab, ...}`)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.core.params import Friction, WorldParams
from kartci.worlds.line_lab.course import LineCourse
from kartci.worlds.parts import Box


class LineLabWorld(WorldParams):
    """White floor with one black line (seed 001, Sec. 5.2.1), plus optional obstacles."""

    kind: Literal["line_lab"] = Field("line_lab", description="world kind: the line lab")
    description: str = Field("", description="one line about the world, shown in reports")
    line_width_m: float = Field(0.014, gt=0.0, lt=0.2, description="width of the black line, "
                                "m (14 mm: with the 14.5 mm camera height, the seed's Eq. 5.2 "
                                "dead-zone field of view of 1.38 rad)")
    light_level: float = Field(
        0.571, gt=0.0, le=1.0,
        description="luminance of the white floor as the line cameras see it (0-1, Eq. 5.1); "
        "calibrated so that the sensor sweep gives the seed's slope, Eq. 6.12 (39.4 per m)",
    )
    floor_friction: Friction = Field(1.0, description="Coulomb friction coefficient of "
                                     "the floor (dimensionless); seed 001 Sec. 5.6: no slip")
    course: LineCourse = Field(description="the black line: `{type: straight, ...}` or "
                               "`{type: circle, ...}`")
    obstacles: tuple[Box, ...] = Field((), description="static boxes on the floor (the sonar "
                                       "sees them, seed 001 Sec. 5.3)")


def line_course(params: LineLabWorld) -> LineCourse:
    """The line lab's course (`WorldKind.course`): its line."""
    return params.course
