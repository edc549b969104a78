"""The indoor hall as a world kind: registered as `hall` (entry point). Its
parameters are `HallWorld`; the simulated world is `kartci.worlds.hall.world.Hall`."""

from kartci.core import Change, Fault, WorldKind, lazy
from kartci.worlds.hall.params import HallWorld

# `kartci faults`: a slipperier surface than the scenario's (dust, a damp patch)
FAULTS = (Fault("floor_friction_x0.8", "the hall's floor at 0.8 of its friction (its zones "
                "keep theirs)",
                (Change.scale("floor_friction", 0.8),)),)

WORLD = WorldKind("hall", HallWorld, lazy("kartci.worlds.hall.world:Hall"),
                  "an indoor hall with walls, pillars, floor zones and a closed track",
                  course=lazy("kartci.worlds.track.model:track_course"),
                  faults=FAULTS)

__all__ = ["WORLD", "HallWorld"]
