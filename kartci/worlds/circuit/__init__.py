"""The outdoor race circuit as a world kind: registered as `circuit` (entry point). Its
parameters are `CircuitWorld`; the simulated world is `kartci.worlds.circuit.world.Circuit`."""

from kartci.core import Change, Fault, WorldKind, lazy
from kartci.worlds.circuit.params import CircuitWorld

# `kartci faults`: a slipperier surface than the scenario's (dust, a damp patch)
FAULTS = (Fault("floor_friction_x0.8", "the circuit's ground at 0.8 of its friction (its "
                "zones keep theirs)",
                (Change.scale("floor_friction", 0.8),)),)

WORLD = WorldKind("circuit", CircuitWorld, lazy("kartci.worlds.circuit.world:Circuit"),
                  "an outdoor race circuit from a TUMFTM track, with optional barriers",
                  course=lazy("kartci.worlds.track.model:track_course"),
                  faults=FAULTS)

__all__ = ["WORLD", "CircuitWorld"]
