"""The parameter base classes every plugin's own pydantic model extends: a scenario names a
registered type and that type's model validates its part of the file."""

from __future__ import annotations

import math
from typing import Annotated

from pydantic import BaseModel, ConfigDict, Field

# --- physical bounds: every numeric key is bounded by what its unit (the key's suffix) can mean
# for a kart or a line tracker, generously (every shipped scenario is far inside), so that no
# value runs nonsense physics or overflows geometry. A key's own bounds narrow these:
#   m +-1e4 (10 km: wider than any race circuit), m/s +-100 (a kart tops 30 m/s),
#   m/s^2 +-100 (10 g), m/s^3 +-1e4, s +-3600 (the longest run; periods > 0), Hz 0-1e5,
#   rad +-2 pi, rad/s +-1e3 (a kart's wheel spins at 250 rad/s), kg, kg m^2, N m 0-1e5,
#   1/m +-1e3, 1/s +-1e4, per sqrt(s) 0-1e3, friction 0-10 (rubber: about 1),
#   dimensionless gains, weights and scales +-1e6, pixels 1-8192, counts 0-1e6.
# The shapes most keys share, as types (`period_s: Period_s = Field(0.02, description=...)`):
Length_m = Annotated[float, Field(ge=-1e4, le=1e4)]  # a length, offset or coordinate
Size_m = Annotated[float, Field(gt=0.0, le=1e4)]  # a size, range or spread: none is no body
Distance_m = Annotated[float, Field(ge=0.0, le=1e4)]  # a distance or margin, 0 allowed
Angle_rad = Annotated[float, Field(ge=-2 * math.pi, le=2 * math.pi)]
Period_s = Annotated[float, Field(gt=0.0, le=3600.0)]  # a period or a time that must pass
Duration_s = Annotated[float, Field(ge=0.0, le=3600.0)]  # a time into a run, or a hold, 0 allowed
Friction = Annotated[float, Field(ge=0.0, le=10.0)]  # a friction coefficient
Gain = Annotated[float, Field(ge=-1e6, le=1e6)]  # a dimensionless gain, weight or scale
Count = Annotated[int, Field(ge=1, le=1_000_000)]  # a count of at least one


class Frozen(BaseModel):
    """Base for every spec: immutable, and unknown keys are errors, not silently ignored."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


class ControllerParams(Frozen):
    """Parameters of a controller type (`controller: {type: NAME, ...}`)."""

    type: str = Field(description="a registered controller (`kartci plugins`)")
    period_s: Period_s = Field(0.02, description="control period, s: a whole multiple of "
                               "physics.dt_s")


class NodeParams(Frozen):
    """Parameters of a node type (`agents.<name>.nodes: {NAME: {...}}`): localization, a
    detector, anything that runs beside the controller in the robot's namespace."""

    period_s: Period_s = Field(0.02, description="node period, s: a whole multiple of "
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
