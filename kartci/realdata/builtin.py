"""The registered pieces an imported log is described with: a world, a robot kind and a
controller named `recorded` (the log's own robot drove; nothing here can be simulated), and the
metric set `motion`, which any scenario can use too (an estimate is judged by the
`localization` set)."""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from kartci.core import (
    Controller,
    ControllerParams,
    MetricSet,
    RobotKind,
    RobotParams,
    WorldKind,
    WorldParams,
    lazy,
)
from kartci.errors import SpecError
from kartci.realdata.divergence import DEFS as SIMREAL_DEFS
from kartci.realdata.divergence import SimrealParams, simreal_metrics
from kartci.realdata.motion import (
    MOTION_DEFS,
    TRACK_DEFS,
    motion_metrics,
)


class RecordedWorld(WorldParams):
    """Wherever an imported log was recorded: known only by its track, if there is one."""

    kind: Literal["recorded"] = Field("recorded", description="world kind: where a log was "
                                      "recorded")
    track: str | None = Field(None, description="the TUMFTM track the log was driven on")


class RecordedRobot(RobotParams):
    """A robot known only from its log."""

    kind: Literal["recorded"] = Field("recorded", description="robot kind: a logged robot")
    urdf: str = Field("", description="none: a recorded robot is not simulated")


class RecordedController(ControllerParams):
    """Whatever drove the robot of an imported log."""

    type: Literal["recorded"] = Field("recorded", description="controller type: the log's "
                                      "own driver")


def _not_simulated(*args: Any) -> Any:
    raise SpecError("an imported log's robot, world and driver are recorded, not simulated; "
                    "use `kartci simreal --scenario` to simulate a log's commands")


WORLD = WorldKind("recorded", RecordedWorld, _not_simulated,
                  "where an imported log was recorded (not simulated)")
ROBOT = RobotKind("recorded", RecordedRobot, _not_simulated, ("motion",),
                  lazy("kartci.realdata.plots:recorded_plots"),
                  "a robot known only from an imported log (not simulated)")
CONTROLLER = Controller("recorded", RecordedController, _not_simulated, (),
                        "whatever drove an imported log's robot (not simulated)")
MOTION = MetricSet("motion", {**MOTION_DEFS, **TRACK_DEFS}, motion_metrics, None, (),
                   "duration, distance, speeds, yaw rate of the odometry; laps, lap times, "
                   "progress and cross-track error when the log holds a track")
SIMREAL = MetricSet("simreal", SIMREAL_DEFS, simreal_metrics, SimrealParams, (),
                    "divergence of the simulated robot from a log it replayed (kartci simreal)")
