"""What every world around a closed race track has in its parameters (each kind documents its
own keys again, with its own defaults and reasons)."""

from __future__ import annotations

from pydantic import Field

from kartci.core.params import Friction, Frozen, WorldParams
from kartci.scenario.models import Point_m
from kartci.worlds.parts import Box


class FloorZone(Frozen):
    """A rectangle of floor with its own friction coefficient (mu = pull force / weight)."""

    name: str = Field(description="name of the surface, e.g. `coated`")
    min_m: Point_m = Field(description="lower-left corner (x, y), m, world frame")
    max_m: Point_m = Field(description="upper-right corner (x, y), m, world frame")
    friction: Friction = Field(description="friction coefficient mu = pull force / "
                               "weight (seed 000 Sec. 4.2; REFERENCE.md: about 0.6 for a coated "
                               "floor)")


class TrackWorldParams(WorldParams):
    """What every world around a closed race track has (each kind documents its own)."""

    track: str = Field(description="closed track, TUMFTM CSV on the project's world path")
    floor_friction: Friction = Field(0.9, description="friction coefficient of the floor")
    zones: tuple[FloorZone, ...] = Field((), description="areas with their own friction")
    obstacles: tuple[Box, ...] = Field((), description="static boxes on the floor")
