"""The line lab (seed 001) as a world kind: registered as `line_lab` (entry point).

Public for robots that follow its line: the parameters (`LineLabWorld`) and the two course
shapes (`StraightCourse`, `CircleCourse`), each answering `kartci.core.course.Course`; the
simulated world is `kartci.worlds.line_lab.world.LineLab`.
"""

from kartci.core import Change, Fault, WorldKind, lazy
from kartci.worlds.line_lab.course import CircleCourse, LineCourse, StraightCourse
from kartci.worlds.line_lab.params import LineLabWorld

# `kartci faults`: a slipperier surface than the scenario's (dust, a damp patch)
FAULTS = (Fault("floor_friction_x0.8", "the lab's floor at 0.8 of its friction",
                (Change.scale("floor_friction", 0.8),)),)

WORLD = WorldKind("line_lab", LineLabWorld, lazy("kartci.worlds.line_lab.world:LineLab"),
                  "a white floor with one black line (straight or circle)",
                  course=lazy("kartci.worlds.line_lab.params:line_course"),
                  faults=FAULTS)

__all__ = ["WORLD", "CircleCourse", "LineCourse", "LineLabWorld", "StraightCourse"]
