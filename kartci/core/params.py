"""The parameter base classes every plugin's own pydantic model extends: a scenario names a
registered type and that type's model validates its part of the file."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field


class Frozen(BaseModel):
    """Base for every spec: immutable, and unknown keys are errors, not silently ignored."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


class ControllerParams(Frozen):
    """Parameters of a controller type (`controller: {type: NAME, ...}`)."""

    type: str = Field(description="a registered controller (`kartci plugins`)")
    period_s: float = Field(0.02, gt=0.0, le=3600.0,
                            description="control period, s: a whole multiple of "
                            "physics.dt_s")


class NodeParams(Frozen):
    """Parameters of a node type (`agents.<name>.nodes: {NAME: {...}}`): localization, a
    detector, anything that runs beside the controller in the robot's namespace."""

    period_s: float = Field(0.02, gt=0.0, le=3600.0,
                            description="node period, s: a whole multiple of "
                            "physics.dt_s")


class RobotParams(Frozen):
    """Parameters of a robot kind (`model: {kind: NAME, ...}` or a model folder's params)."""

    kind: str = Field(description="a registered robot kind")
    urdf: str = Field(description="the robot's URDF: absolute, or relative to <kind>/ on the "
                      "project's model path")


class WorldParams(Frozen):
    """Parameters of a world kind (`world: {kind: NAME, ...}` or a world file)."""

    kind: str = Field(description="a registered world kind")
    description: str = Field("", description="one line about the world, shown in reports")


class MetricParams(Frozen):
    """Parameters of a metric set (`metrics: {NAME: {...}}`)."""
