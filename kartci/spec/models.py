"""Typed, frozen scenario specs. Units are in the key names (SI, radians)."""

from __future__ import annotations

import math
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, SerializeAsAny, model_validator


class Frozen(BaseModel):
    """Base for every spec: immutable, and unknown keys are errors, not silently ignored."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


# a coordinate in a world, bounded so that geometry on it (squares, lengths) cannot overflow
Coordinate_m = Annotated[float, Field(ge=-1e6, le=1e6)]
Point_m = tuple[Coordinate_m, Coordinate_m]


# --- what plugins extend: each registered type validates its own parameters -----------------


class ControllerParams(Frozen):
    """Parameters of a controller type (`controller: {type: NAME, ...}`)."""

    type: str = Field(description="a registered controller (`kartci plugins`)")
    period_s: float = Field(0.02, gt=0.0, description="control period, s: a whole multiple of "
                            "physics.dt_s")


class RobotParams(Frozen):
    """Parameters of a robot kind (`model: {kind: NAME, ...}` or a model folder's params)."""

    kind: str = Field(description="a registered robot kind")
    urdf: str = Field(description="the robot's URDF: absolute, or relative to <kind>/ on the "
                      "project's model path")


class WorldParams(Frozen):
    """Parameters of a world kind (`world: {kind: NAME, ...}` or a world file)."""

    kind: str = Field(description="a registered world kind")
    description: str = ""


class MetricParams(Frozen):
    """Parameters of a metric set (`metrics: {NAME: {...}}`)."""


# --- worlds -----------------------------------------------------------------------------------


class StraightCourse(Frozen):
    """A straight black line from `start_m` to `end_m`."""

    type: Literal["straight"] = "straight"
    start_m: Point_m = (0.0, 0.0)
    end_m: Point_m = (2.5, 0.0)

    @model_validator(mode="after")
    def _has_length(self) -> StraightCourse:
        if (self.end_m[0] - self.start_m[0]) ** 2 + (self.end_m[1] - self.start_m[1]) ** 2 < 1e-4:
            raise ValueError("end_m must be at least 0.01 m from start_m")
        return self


class CircleCourse(Frozen):
    """A closed circular black line, driven counter-clockwise from angle `start_rad`."""

    type: Literal["circle"] = "circle"
    center_m: Point_m = (0.0, 0.0)
    radius_m: float = Field(1.0, gt=0.05, le=1e6)
    start_rad: float = -1.5707963267948966


Course = Annotated[StraightCourse | CircleCourse, Field(discriminator="type")]


class Box(Frozen):
    """A static box obstacle standing on the floor."""

    center_m: tuple[float, float]
    size_m: tuple[float, float, float] = (0.1, 0.1, 0.1)
    yaw_rad: float = 0.0


class LineLabWorld(WorldParams):
    """White floor with one black line (seed 001, Sec. 5.2.1), plus optional obstacles."""

    kind: Literal["line_lab"] = "line_lab"
    description: str = ""
    line_width_m: float = Field(0.014, gt=0.0, lt=0.2)
    light_level: float = Field(
        0.571, gt=0.0, le=1.0,
        description="luminance of the white floor as the line cameras see it (0-1)",
    )
    floor_friction: float = Field(1.0, ge=0.0)
    course: Course
    obstacles: tuple[Box, ...] = ()


class FloorZone(Frozen):
    """A rectangle of floor with its own friction coefficient (mu = pull force / weight)."""

    name: str
    min_m: tuple[float, float]
    max_m: tuple[float, float]
    friction: float = Field(ge=0.0)


class HallWorld(WorldParams):
    """An indoor hall: walls, pillars, a ceiling, floor zones and a closed TUMFTM track."""

    kind: Literal["hall"] = "hall"
    description: str = ""
    size_m: tuple[float, float] = Field((32.0, 20.0), description="interior, from (0, 0)")
    wall_height_m: float = Field(4.0, gt=0.5)
    wall_thickness_m: float = 0.3
    pillars_m: tuple[tuple[float, float], ...] = ()
    pillar_size_m: float = 0.5
    floor_friction: float = Field(0.9, ge=0.0, description="tire on concrete")
    zones: tuple[FloorZone, ...] = ()
    track: str = Field(description="TUMFTM CSV, relative to sims/ (or absolute)")
    obstacles: tuple[Box, ...] = ()


class CircuitWorld(WorldParams):
    """An outdoor race circuit from a TUMFTM track alone: ground sized to the track, optional
    barriers along both edges, no hall."""

    kind: Literal["circuit"] = "circuit"
    description: str = ""
    track: str = Field(description="TUMFTM CSV on the project's world path (or absolute)")
    margin_m: float = Field(10.0, ge=1.0, description="ground beyond the track's extent, m")
    floor_friction: float = Field(0.9, ge=0.0, description="tyre on asphalt or concrete")
    zones: tuple[FloorZone, ...] = Field((), description="areas with their own friction")
    barriers: bool = Field(True, description="walls along both track edges")
    barrier_offset_m: float = Field(1.0, ge=0.0, description="gap from the track edge to the "
                                    "barrier's inner face, m")
    barrier_height_m: float = Field(0.8, gt=0.0, description="barrier height, m")
    barrier_thickness_m: float = Field(0.3, gt=0.0, description="barrier thickness, m")
    barrier_segment_m: float = Field(3.0, gt=0.2, description="length of one barrier box "
                                     "along the edge, m (shorter follows curves closer)")
    obstacles: tuple[Box, ...] = Field((), description="static boxes on or beside the track")


# --- agents -----------------------------------------------------------------------------------


class LogSource(Frozen):
    """Messages recorded in a log (ROS 1 bag, rosbag2 folder or MCAP), re-based to sim time."""

    log: str = Field(description="path, relative to the project root or absolute")
    topic: str | None = Field(None, description="default: the only topic of a suitable type")
    time_offset_s: float = Field(0.0, description="sim time of the log's first message")


class Pose2D(Frozen):
    """Start pose of the line-sensor midpoint relative to the course start, course frame."""

    along_m: float = Field(0.0, ge=0.0, description="distance along the course from its start")
    lateral_m: float = Field(0.0, description="left of the line is positive")
    heading_rad: float = 0.0


class AgentSpec(Frozen):
    """One robot in the scenario: its model, its controller, where it starts, its sensors."""

    model: SerializeAsAny[RobotParams]
    controller: SerializeAsAny[ControllerParams]
    start: Pose2D = Pose2D()
    sensors: SerializeAsAny[Frozen] = Field(
        default_factory=Frozen, description="the robot kind's sensors: {NAME: {...}}")


# --- scenario ---------------------------------------------------------------------------------


class PhysicsSpec(Frozen):
    dt_s: float = Field(0.002, ge=1e-5, le=0.01)
    odom_rate_hz: float = Field(50.0, gt=0.0)


class LineMetricsParams(MetricParams):
    """Parameters of the line tracker's tracking metrics."""

    transient_s: float = Field(5.0, ge=0.0, description="start-up transient excluded from errors")
    lost_threshold_m: float = Field(0.021, gt=0.0, description="sensor range; beyond it = lost")
    settle_band_m: float = Field(0.002, gt=0.0)


class Criterion(Frozen):
    """A pass criterion on one metric; any combination of bounds."""

    max: float | None = None
    min: float | None = None
    equal: float | None = None


class Scenario(Frozen):
    """A validated scenario: world, agents, duration, seed, metrics and pass criteria."""

    name: str = Field(pattern=r"^[a-z0-9_]+$")
    description: str
    world: SerializeAsAny[WorldParams]
    agents: dict[str, AgentSpec] = Field(min_length=1)
    duration_s: float = Field(gt=0.0, le=3600.0)
    seed: int = Field(0, ge=0)
    physics: PhysicsSpec = PhysicsSpec()
    metrics: dict[str, SerializeAsAny[MetricParams]] = Field(
        {}, description="metric sets to compute besides the robots' own, and parameters of "
        "any set: {NAME: {...}}")
    criteria: dict[str, Criterion] = {}
    tags: tuple[str, ...] = ()

    @model_validator(mode="before")
    @classmethod
    def _registered_types(cls, data: Any) -> Any:
        """Step one of validation: registered type names pick each part's parameter model."""
        from kartci.spec.dispatch import dispatch

        return dispatch(data)

    @model_validator(mode="after")
    def _rates_are_multiples_of_the_physics_step(self) -> Scenario:
        """Controller and sensor periods must be whole multiples of the physics step."""
        dt = self.physics.dt_s
        periods = {"physics.odom_rate_hz": 1.0 / self.physics.odom_rate_hz}
        for name, agent in self.agents.items():
            periods[f"agents.{name}.controller.period_s"] = agent.controller.period_s
        for key, period in periods.items():
            ratio = period / dt
            if not math.isfinite(ratio) or abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
                raise ValueError(
                    f"{key}: period {period:g} s is not a whole multiple of physics.dt_s {dt:g} s"
                )
        return self
