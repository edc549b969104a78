"""The indoor hall as a world kind: registered as `hall` (entry point). Its
parameters are `HallWorld`; the simulated world is `kartci.worlds.hall.world.Hall`."""

from kartci.core import WorldKind, lazy
from kartci.worlds.hall.params import HallWorld

WORLD = WorldKind("hall", HallWorld, lazy("kartci.worlds.hall.world:Hall"),
                  "an indoor hall with walls, pillars, floor zones and a closed track",
                  course=lazy("kartci.worlds.track.model:track_course"))

__all__ = ["WORLD", "HallWorld"]
