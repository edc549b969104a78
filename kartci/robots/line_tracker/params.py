"""The line tracker's parameters and sensors (seed 001, annex model.sdf); units in the key names."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.errors import SpecError
from kartci.spec.models import Frozen, LineLabWorld, RobotParams, Scenario


class LineTrackerModel(RobotParams):
    """Differential-drive line tracker of seed 001 (annex model.sdf, Sec. 5.4)."""

    kind: Literal["line_tracker"] = "line_tracker"
    urdf: str = "line_tracker.urdf"
    wheel_radius_m: float = 0.035
    wheel_separation_m: float = 0.15
    wheel_speed_limit_radps: float = 18.46
    wheel_time_constant_s: float = Field(0.1, ge=0.0)
    wheel_torque_limit_nm: float = Field(0.5, gt=0.0)
    tire_friction: float = Field(1.0, ge=0.0)
    sensor_point_x_m: float = Field(0.095, description="line-sensor midpoint ahead of base_link")


class LineSensorSpec(Frozen):
    """Two downward cameras averaging luminance (Eq. 5.1) over their image."""

    mode: Literal["geometric", "rendered"] = "geometric"
    fov_rad: float = Field(1.2, gt=0.05, lt=3.0)
    resolution_px: int = Field(24, ge=4, le=256, description="rendered image side, pixels")
    noise_std: float = Field(0.001, ge=0.0, description="luminance noise, 1 sigma (0-1 scale)")


class SonarSpec(Frozen):
    """HC-SR04 ultrasonic range finder (seed 001, Sec. 5.3)."""

    enabled: bool = True
    min_range_m: float = 0.02
    max_range_m: float = 4.0
    cone_radius_m: float = Field(1.07, description="cone radius at max range")
    resolution_m: float = 0.003
    rays: int = Field(9, ge=1, le=64)


class LineTrackerSensors(Frozen):
    """The two-camera line sensor and the sonar."""

    line_sensor: LineSensorSpec = LineSensorSpec()
    sonar: SonarSpec = SonarSpec()


def line_parts(scenario: Scenario, agent: str) -> tuple[LineLabWorld, LineTrackerModel]:
    """The line lab and the line tracker of a line-tracker scenario, or a SpecError."""
    world, model = scenario.world, scenario.agents[agent].model
    if not isinstance(world, LineLabWorld) or not isinstance(model, LineTrackerModel):
        raise SpecError(f"scenario {scenario.name}: agent {agent} is not a line tracker in a "
                        "line lab")
    return world, model
