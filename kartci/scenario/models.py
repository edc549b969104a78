"""Typed, frozen scenario specs. Units are in the key names (SI, radians)."""

from __future__ import annotations

import math
import re
from typing import Any

from pydantic import (
    Field,
    PrivateAttr,
    SerializeAsAny,
    ValidationInfo,
    field_validator,
    model_validator,
)

from kartci.core.params import Angle_rad as Angle_rad
from kartci.core.params import ControllerParams as ControllerParams
from kartci.core.params import Distance_m, Duration_s, Period_s
from kartci.core.params import Frozen as Frozen
from kartci.core.params import Length_m as Length_m
from kartci.core.params import MetricParams as MetricParams
from kartci.core.params import NodeParams as NodeParams
from kartci.core.params import RobotParams as RobotParams
from kartci.core.params import WorldParams as WorldParams
from kartci.project import Project
from kartci.scenario.dispatch import dispatch, registries_of
from kartci.scenario.yamlio import preview

Coordinate_m = Length_m  # a coordinate in a world
Point_m = tuple[Coordinate_m, Coordinate_m]
LATERAL_MAX_M = 100.0  # a start this far beside a line or centreline is off any course
UNITS = {"_mps2": "m/s^2", "_mps3": "m/s^3", "_mps": "m/s",
         "_radps": "rad/s", "_rad": "rad", "_kgm2": "kg m^2", "_kg": "kg", "_nm": "N m",
         "_hz": "Hz", "_px": "px", "_per_m": "1/m", "_per_s": "1/s", "_m": "m", "_s": "s"}


def unit_of(key: str) -> str:
    """The unit a key's name states (`v1_mps`: m/s), or '' for a dimensionless one."""
    if key.endswith("_per_sqrt_s"):
        return f"{unit_of(key.removesuffix('_per_sqrt_s'))}/sqrt(s)"
    return next((unit for suffix, unit in UNITS.items() if key.endswith(suffix)), "")


# --- agents -----------------------------------------------------------------------------------


class LogSource(Frozen):
    """Messages recorded in a log (ROS 1 bag, rosbag2 folder or MCAP), re-based to sim time."""

    log: str = Field(description="path of the log (.bag, rosbag2 folder, .db3 or .mcap), "
                     "relative to the scenario file, or absolute")
    topic: str | None = Field(None, description="topic to replay; default: the only topic of a "
                              "suitable message type")
    time_offset_s: float = Field(0.0, ge=-3600.0, le=3600.0,
                                 description="sim time of the log's first message, s")


class Pose2D(Frozen):
    """Start pose relative to the course start, in the course frame: of the line-sensor
    midpoint for a line tracker, of base_link for a kart (along the track's centreline)."""

    along_m: Distance_m = Field(0.0, description="distance along the course (line or track "
                                "centreline) from its start, m")
    lateral_m: float = Field(0.0, ge=-LATERAL_MAX_M, le=LATERAL_MAX_M, description="offset "
                                "from the line or centreline, m; left of it is positive; on a "
                                "track, within the track's width there")
    heading_rad: Angle_rad = Field(0.0, description="heading relative to the course direction at "
                                   "that point, rad; counter-clockwise is positive")


class Carry(Frozen):
    """The robot carried once, without its knowledge (a kidnap): its pose jumps, its motion
    is kept."""

    at_s: Duration_s = Field(description="when, sim time, s")
    offset_m: Point_m = Field(description="the jump (x, y) in the world frame, m")
    yaw_rad: Angle_rad = Field(0.0, description="turned by this much too, rad")


class AgentSpec(Frozen):
    """One robot in the scenario: its model, its controller, where it starts, its sensors."""

    model: SerializeAsAny[RobotParams] = Field(description="the robot: a model folder's name "
                                               "(`NAME/params.yaml` on the model path) or "
                                               "`{kind: NAME, ...}` with its parameters")
    controller: SerializeAsAny[ControllerParams] = Field(description="what drives the robot: "
                                                         "`{type: NAME, ...}`, a registered "
                                                         "controller and its parameters")
    start: Pose2D = Field(Pose2D(), description="start pose relative to the course start")
    sensors: SerializeAsAny[Frozen] = Field(
        default_factory=Frozen, description="the robot kind's sensors: {NAME: {...}}")
    nodes: dict[str, SerializeAsAny[NodeParams]] = Field(
        {}, description="nodes beside the controller (localization, obstacle_detector, ...): "
        "{NAME: {...}}, each a registered node and its parameters (`kartci plugins`)")
    carry: Carry | None = Field(None, description="carry the robot once mid-run (a kidnap): "
                                "for robots that can be re-placed (go-kart, line tracker)")


# An agent name is a ROS 2 name token (design.ros2.org "Topic and Service name mapping to DDS":
# alphanumerics and `_`, no leading digit, no repeated `_`; tokens do not end in `_`); kartci's
# own limit on its length keeps `/<agent>/<longest topic>` far inside rmw's 255 characters.
AGENT_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*(?<!_)")
AGENT_NAME_MAX = 64  # characters


# --- scenario ---------------------------------------------------------------------------------


class PhysicsSpec(Frozen):
    """The simulation's clock: a fixed physics step, sim time only."""

    dt_s: float = Field(0.002, ge=1e-5, le=0.01, description="fixed physics step, s; every "
                        "controller period and sensor rate is a whole multiple of it (seed 001 "
                        "Sec. 7.2 ran its fastest control at 0.002 s)")
    odom_rate_hz: float = Field(50.0, gt=0.0, le=1e5,
                                description="rate of each robot's ground-truth "
                                "odometry (`odom`, nav_msgs/Odometry), Hz")


class Criterion(Frozen):
    """A pass criterion on one metric; any combination of bounds."""

    max: float | None = Field(None, description="the metric must be at most this, in the "
                              "metric's unit")
    min: float | None = Field(None, description="the metric must be at least this, in the "
                              "metric's unit")
    equal: float | None = Field(None, description="the metric must equal this, in the metric's "
                                "unit")


class Scenario(Frozen):
    """One scenario file: a world, its agents, how long, which metrics and pass criteria."""

    name: str = Field(pattern=r"^[a-z0-9_]+$", description="the scenario's name: lower-case "
                      "letters, digits and _; default: the file name without .yaml")
    description: str = Field(description="one line saying what the scenario checks, shown by "
                             "`kartci list` and in reports")
    world: SerializeAsAny[WorldParams] = Field(description="the world: a world file's name on "
                                               "the search path (e.g. `winti/hall`), "
                                               "`{from: NAME, KEY: value}` to change some keys "
                                               "of one, or `{kind: NAME, ...}` in full")
    agents: dict[str, AgentSpec] = Field(min_length=1, description="the robots by name; the "
                                         "name is their topic namespace (`/kart0/...`)")
    duration_s: Period_s = Field(description="simulated time to run, s")
    seed: int = Field(0, ge=0, le=2**63 - 1, description="seed of the run's one random "
                      "generator (fits an int64): the same scenario and seed give the same "
                      "numbers on every run")
    physics: PhysicsSpec = Field(PhysicsSpec(), description="physics step and odometry rate")
    metrics: dict[str, SerializeAsAny[MetricParams]] = Field(
        {}, description="metric sets to compute besides the robots' own, and parameters of "
        "any set: {NAME: {...}}")
    criteria: dict[str, Criterion] = Field({}, description="pass criteria by metric name: "
                                           "a bare name judges every agent's metric, "
                                           "`agent.metric` one agent's; a failed criterion "
                                           "fails the run (exit 1)")
    tags: tuple[str, ...] = Field((), description="free labels; `tool` keeps a scenario out of "
                                  "a plain `kartci run` (run it by name)")
    sweep: dict[str, tuple[float | int | bool | str, ...]] = Field(
        {}, description="a grid: `dotted.key: [values]`, one run per combination when the "
        "scenario is run by name without `--sweep` (each point judged against its own baseline, "
        "`<scenario>@<key>=<value>`); a scenario with a sweep stays out of a plain `kartci run`")
    # the project it was loaded in (`kartci.scenario.load.in_project`): not part of the
    # scenario's value (never dumped, hashed or recorded), but carried with it to every process
    _project: Project | None = PrivateAttr(None)

    @property
    def project(self) -> Project | None:
        """The project the scenario was loaded in, whose folders its controllers and nodes
        find their data files in; None for one built by hand (kartci's own data only)."""
        return self._project

    def attach(self, project: Project) -> None:
        """Carry `project` (see `project`): done once, by the loader, to a fresh copy."""
        self._project = project

    def __eq__(self, other: object) -> bool:
        """Equal values are equal scenarios, whichever project each was loaded in."""
        if not isinstance(other, Scenario):
            return NotImplemented
        return type(self) is type(other) and self.__dict__ == other.__dict__

    @field_validator("agents")
    @classmethod
    def _agent_names_are_ros_names(cls, agents: dict[str, AgentSpec]) -> dict[str, AgentSpec]:
        """An agent's name is its topics' namespace (`/<name>/odom`), so it must be one ROS 2
        name token: what rcl, rmw and rosbags accept, and never a path (`../../etc`)."""
        for name in agents:
            if not AGENT_NAME.fullmatch(name) or "__" in name or len(name) > AGENT_NAME_MAX:
                raise ValueError(f"agent name {preview(name, 40)} is not a ROS 2 name token: "
                                 "a letter, then letters, digits and single underscores, not "
                                 f"ending in one, at most {AGENT_NAME_MAX} characters (e.g. kart0)")
        return agents

    @model_validator(mode="before")
    @classmethod
    def _registered_types(cls, data: Any, info: ValidationInfo) -> Any:
        """Step one of validation: registered type names pick each part's parameter model, in
        the registries the caller handed over (`dispatch.context`)."""
        return dispatch(data, registries_of(info))

    @model_validator(mode="after")
    def _rates_are_multiples_of_the_physics_step(self) -> Scenario:
        """Controller and sensor periods must be whole multiples of the physics step."""
        dt = self.physics.dt_s
        periods = {"physics.odom_rate_hz": 1.0 / self.physics.odom_rate_hz}
        for name, agent in self.agents.items():
            periods[f"agents.{name}.controller.period_s"] = agent.controller.period_s
            for node, params in agent.nodes.items():
                periods[f"agents.{name}.nodes.{node}.period_s"] = params.period_s
        for key, period in periods.items():
            ratio = period / dt
            if not math.isfinite(ratio) or abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
                raise ValueError(
                    f"{key}: period {period:g} s is not a whole multiple of physics.dt_s {dt:g} s"
                )
        return self
