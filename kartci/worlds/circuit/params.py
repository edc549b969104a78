"""The circuit's parameters (`world: {kind: circuit, ...}`)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.core.params import Distance_m, Friction, Size_m
from kartci.worlds.parts import Box
from kartci.worlds.track.params import FloorZone, TrackWorldParams


class CircuitWorld(TrackWorldParams):
    """An outdoor race circuit from a TUMFTM track alone: ground sized to the track, optional
    barriers along both edges, no hall."""

    kind: Literal["circuit"] = Field("circuit", description="world kind: an outdoor race "
                                     "circuit")
    description: str = Field("", description="one line about the world, shown in reports")
    track: str = Field(description="closed track, TUMFTM CSV `x_m,y_m,w_tr_right_m,"
                       "w_tr_left_m`: relative to a world folder on the project's search path, "
                       "or absolute")
    margin_m: float = Field(10.0, ge=1.0, le=1e4, description="ground beyond the track's extent, m")
    floor_friction: Friction = Field(0.9, description="friction coefficient of the ground "
                                     "(mu, dimensionless): tyre on asphalt or concrete, about 0.9 "
                                     "(REFERENCE.md)")
    zones: tuple[FloorZone, ...] = Field((), description="areas with their own friction")
    barriers: bool = Field(True, description="walls along both track edges")
    barrier_offset_m: Distance_m = Field(1.0, description="gap from the track edge to the "
                                         "barrier's inner face, m")
    barrier_height_m: Size_m = Field(0.8, description="barrier height, m")
    barrier_thickness_m: Size_m = Field(0.3, description="barrier thickness, m")
    barrier_segment_m: float = Field(3.0, gt=0.2, le=1e4, description="length of one barrier box "
                                     "along the edge, m (shorter follows curves closer)")
    obstacles: tuple[Box, ...] = Field((), description="static boxes on or beside the track")
