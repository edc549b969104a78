"""The line tracker's parameters and sensors (source document 001, annex model.sdf); units in the
key names."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.core import Frozen, RobotParams
from kartci.core.params import Duration_s, Friction, Length_m
from kartci.errors import SpecError
from kartci.scenario.models import Scenario
from kartci.worlds.line_lab import LineLabWorld


class LineTrackerModel(RobotParams):
    """Differential-drive line tracker of source document 001 (annex model.sdf, Sec. 5.4)."""

    kind: Literal["line_tracker"] = Field("line_tracker", description="robot kind: the "
                                          "line tracker")
    urdf: str = Field("line_tracker.urdf", description="the robot's URDF: absolute, or "
                      "relative to line_tracker/ on the project's model path")
    wheel_radius_m: Length_m = Field(0.035, description="drive wheel radius, m (annex model.sdf)")
    wheel_separation_m: Length_m = Field(0.15, description="distance between the drive wheels, m "
                                         "(wheels at y = +-0.075 m, annex model.sdf)")
    wheel_speed_limit_radps: float = Field(18.46, ge=-1e3, le=1e3,
                                           description="wheel speed limit, rad/s: the "
                                           "DC motors' measured saturation (Sec. 5.4)")
    wheel_time_constant_s: Duration_s = Field(0.1, description="first-order wheel response "
                                              "time constant, s (Sec. 5.4); 0: ideal wheels")
    wheel_torque_limit_nm: float = Field(0.5, gt=0.0, le=1e5, description="torque limit per wheel "
                                         "motor, N m")
    tire_friction: Friction = Field(1.0, description="tyre friction factor "
                                    "(dimensionless), multiplied by the floor's friction")
    sensor_point_x_m: Length_m = Field(0.095, description="line-sensor midpoint ahead of "
                                       "base_link, m (annex model.sdf camera pose)")
    wheel_drive: Literal["motor", "set_velocity"] = Field(
        "motor", description="`motor`: a torque-limited velocity motor holds each wheel at its "
        "lagged target every physics step; `set_velocity`: the annex TestSensor.cc's "
        "`joint->SetVelocity` once per control tick (Gazebo >= 5 sets the wheel's speed relative "
        "to the chassis at that instant and does not hold it), the wheels roll free in between")
    wheel_mass_kg: float | None = Field(None, gt=0.0, le=1e5,
                                        description="override of each wheel's "
                                        "mass, kg (None: the URDF's 0.03 kg); the annex "
                                        "model.sdf wheels have no <inertial>, so Gazebo used "
                                        "SDF's default 1 kg (Sec. 5.5)")
    wheel_inertia_kgm2: float | None = Field(None, gt=0.0, le=1e5, description="override of each "
                                             "wheel's principal inertias, kg m^2 (None: the "
                                             "URDF's); SDF's default for a link without "
                                             "<inertial> is 1 kg m^2 about each axis")
    caster_friction: Friction = Field(0.0, description="friction factor of the caster "
                                      "sphere, a fixed collision of the chassis that slides "
                                      "(Sec. 5.1.1); 0: frictionless. The annex model.sdf gives "
                                      "it no <surface>, so ODE used min(1 default, floor 100) = 1")


class LineSensorSpec(Frozen):
    """Two downward cameras averaging luminance (Eq. 5.1) over their image."""

    mode: Literal["geometric", "rendered"] = Field("geometric", description="`geometric`: "
                                                   "the ink under each pixel computed from the "
                                                   "floor geometry (fast, exact); `rendered`: "
                                                   "images from PyBullet's renderer")
    fov_rad: float = Field(1.2, gt=0.05, lt=3.0, description="each camera's field of view, rad "
                           "(Sec. 5.2.2: 1.2 rad reproduces the real sensor's +-0.008 m range)")
    resolution_px: int = Field(24, ge=4, le=256, description="rendered image side, pixels")
    noise_std: float = Field(0.001, ge=0.0, le=1e6,
                             description="luminance noise, 1 sigma (0-1 scale)")
    update_rate_hz: float | None = Field(None, gt=0.0, le=1e5, description="camera frame rate on "
                                         "its own clock, Hz; the controller reads the latest "
                                         "frame (annex model.sdf: <update_rate>17 for ts 0.06 s; "
                                         "Sec. 7.2: at most 300 Hz). None: a frame per control "
                                         "tick, taken at the tick")
    latency_frames: int = Field(0, ge=0, le=100, description="frames a published reading "
                                "lags its image: Gazebo's camera sensor renders in one update and "
                                "hands the frame to its plugin (Sec. 6.4, annex CameraDump) in "
                                "the next; 0: published as taken")


class SonarSpec(Frozen):
    """HC-SR04 ultrasonic range finder (source document 001, Sec. 5.3)."""

    enabled: bool = Field(True, description="simulate the sonar (`sonar`, sensor_msgs/Range)")
    min_range_m: Length_m = Field(0.02, description="minimum range, m (Sec. 5.3)")
    max_range_m: Length_m = Field(4.0, description="maximum range, m (Sec. 5.3)")
    cone_radius_m: Length_m = Field(1.07, description="cone radius at max range, m (Sec. 5.3)")
    resolution_m: Length_m = Field(0.003, description="range resolution, m: readings are "
                                   "rounded to it (Sec. 5.3)")
    rays: int = Field(9, ge=1, le=64, description="rays cast per reading: one on the axis and "
                      "the rest on the cone's rim")


class LineTrackerSensors(Frozen):
    """The two-camera line sensor and the sonar."""

    line_sensor: LineSensorSpec = Field(LineSensorSpec(), description="the two downward "
                                        "cameras (`line_sensor`: left and right luminance)")
    sonar: SonarSpec = Field(SonarSpec(), description="the HC-SR04 ultrasonic range finder")


def line_parts(scenario: Scenario, agent: str) -> tuple[LineLabWorld, LineTrackerModel]:
    """The line lab and the line tracker of a line-tracker scenario, or a SpecError."""
    world, model = scenario.world, scenario.agents[agent].model
    if not isinstance(world, LineLabWorld) or not isinstance(model, LineTrackerModel):
        raise SpecError(f"scenario {scenario.name}: agent {agent} is not a line tracker in a "
                        "line lab")
    return world, model
