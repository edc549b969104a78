"""kartci's own world kinds, registered through entry points like any team's."""

from __future__ import annotations

from kartci.core import WorldKind, lazy
from kartci.scenario.models import CircuitWorld, HallWorld, LineLabWorld

LINE_LAB = WorldKind("line_lab", LineLabWorld, lazy("kartci.sim.line_lab:LineLab"),
                     "a white floor with one black line (straight or circle)")
HALL = WorldKind("hall", HallWorld, lazy("kartci.sim.hall:Hall"),
                 "an indoor hall with walls, pillars, floor zones and a closed track")
CIRCUIT = WorldKind("circuit", CircuitWorld, lazy("kartci.sim.circuit:Circuit"),
                    "an outdoor race circuit from a TUMFTM track, with optional barriers")
