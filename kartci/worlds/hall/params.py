"""The hall's parameters (`world: {kind: hall, ...}`)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.core.params import Friction, Size_m
from kartci.scenario.models import Point_m
from kartci.worlds.parts import Box
from kartci.worlds.track.params import FloorZone, TrackWorldParams


class HallWorld(TrackWorldParams):
    """An indoor hall: walls, pillars, a ceiling, floor zones and a closed TUMFTM track."""

    kind: Literal["hall"] = Field("hall", description="world kind: an indoor hall")
    description: str = Field("", description="one line about the world, shown in reports")
    size_m: tuple[Size_m, Size_m] = Field((32.0, 20.0), description="interior (x, y) extent, m, "
                                        "from (0, 0) (an approximation of the Winti lab, "
                                        "REFERENCE.md)")
    wall_height_m: float = Field(4.0, gt=0.5, le=1e4, description="height of walls and pillars, m")
    wall_thickness_m: Size_m = Field(0.3, description="thickness of the walls, m, outside the "
                                     "interior")
    pillars_m: tuple[Point_m, ...] = Field((), description="centres (x, y) of "
                                                       "square pillars, m")
    pillar_size_m: Size_m = Field(0.5, description="side of a square pillar, m")
    floor_friction: Friction = Field(0.9, description="friction coefficient of the floor "
                                     "outside any zone (mu = pull force / weight, seed 000 Sec. "
                                     "4.2); 0.9: tire on concrete (REFERENCE.md)")
    zones: tuple[FloorZone, ...] = Field((), description="rectangles of floor with their own "
                                         "friction (the seed's second, coated surface)")
    track: str = Field(description="closed track, TUMFTM CSV `x_m,y_m,w_tr_right_m,"
                       "w_tr_left_m`: relative to a world folder on the project's search path "
                       "(e.g. `winti/track.csv`), or absolute")
    obstacles: tuple[Box, ...] = Field((), description="static boxes on the floor (seed 000 "
                                       "Sec. 6.5)")
