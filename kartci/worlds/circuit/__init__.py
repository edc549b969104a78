"""The outdoor race circuit as a world kind: registered as `circuit` (entry point). Its
parameters are `CircuitWorld`; the simulated world is `kartci.worlds.circuit.world.Circuit`."""

from kartci.core import WorldKind, lazy
from kartci.worlds.circuit.params import CircuitWorld

WORLD = WorldKind("circuit", CircuitWorld, lazy("kartci.worlds.circuit.world:Circuit"),
                  "an outdoor race circuit from a TUMFTM track, with optional barriers",
                  course=lazy("kartci.worlds.track.model:track_course"))

__all__ = ["WORLD", "CircuitWorld"]
