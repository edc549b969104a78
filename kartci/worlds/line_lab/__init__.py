"""The line lab (seed 001) as a world kind: registered as `line_lab` (entry point).

Public for robots that follow its line: the parameters (`LineLabWorld`) and the two course
shapes (`StraightCourse`, `CircleCourse`), each answering `kartci.core.course.Course`; the
simulated world is `kartci.worlds.line_lab.world.LineLab`.
"""

from kartci.core import WorldKind, lazy
from kartci.worlds.line_lab.course import CircleCourse, LineCourse, StraightCourse
from kartci.worlds.line_lab.params import LineLabWorld

WORLD = WorldKind("line_lab", LineLabWorld, lazy("kartci.worlds.line_lab.world:LineLab"),
                  "a white floor with one black line (straight or circle)",
                  course=lazy("kartci.worlds.line_lab.params:line_course"))

__all__ = ["WORLD", "CircleCourse", "LineCourse", "LineLabWorld", "StraightCourse"]
