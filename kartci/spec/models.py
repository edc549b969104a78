"""Typed, frozen scenario specs. Units are in the key names (SI, radians)."""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from kartci.errors import SpecError


class Frozen(BaseModel):
    """Base for every spec: immutable, and unknown keys are errors, not silently ignored."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False)


# a coordinate in a world, bounded so that geometry on it (squares, lengths) cannot overflow
Coordinate_m = Annotated[float, Field(ge=-1e6, le=1e6)]
Point_m = tuple[Coordinate_m, Coordinate_m]


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


class LineLabWorld(Frozen):
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


class HallWorld(Frozen):
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


World = Annotated[LineLabWorld | HallWorld, Field(discriminator="kind")]


# --- robots, sensors, controllers ----------------------------------------------------------


class LineTrackerModel(Frozen):
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


class LinePidController(Frozen):
    """P / PI tracking controller of the seed's TestSensor.cc (Eq. 6.13, wheel-speed law)."""

    type: Literal["line_pid"] = "line_pid"
    kp: float = 50.0
    ki: float = 0.0
    period_s: float = Field(0.01, gt=0.0)
    v1_mps: float = 0.1
    stop_range_m: float = Field(0.1, description="stop when the sonar reads less than this")
    slope_m: float = Field(0.0254, description="d = slope_m * y + offset_m (Eq. 6.13)")
    offset_m: float = -0.000091365
    half_track_m: float = Field(0.06, description="lever in the annex wheel-speed law")


class GokartModel(Frozen):
    """The ETH go-kart (seed 000, Tables 3.1, 3.2, 3.4); limits from REFERENCE.md."""

    kind: Literal["gokart"] = "gokart"
    variant: Literal["bumblebee", "herbie"] = "bumblebee"
    urdf: str = "bumblebee.urdf"
    rear_wheel_radius_m: float = 0.127
    front_wheel_radius_m: float = 0.117
    wheel_torque_limit_nm: float = Field(95.0, description="per rear wheel")
    max_speed_mps: float = 10.0
    max_accel_mps2: float = 5.0
    max_brake_mps2: float = 8.0
    reverse_speed_mps: float = 2.0
    steering: Literal["measured", "ackermann"] = "measured"
    steering_limit_rad: tuple[float, float] = Field((-1.845, 1.732), description="column angle")
    steering_rate_radps: float = Field(4.0, description="column angle slew rate")
    wheelbase_m: float = Field(1.27, description="l of Eq. 3.1/3.2 (Ackermann option)")
    track_m: float = Field(0.94, description="w of Eq. 3.1/3.2 (Ackermann option)")
    tire_friction: float = 1.0
    wheel_xy_m: tuple[tuple[float, float], ...] = Field(
        ((-0.077, 0.5625), (-0.077, -0.5625), (1.129, 0.47), (1.129, -0.47)),
        description="rl, rr, fl, fr wheel centres in base_link (Table 3.2)")


class LidarSpec(Frozen):
    """Velodyne VLP-16 or HDL-32E (Table 3.5) on velodyne_link."""

    enabled: bool = False
    model: Literal["vlp16", "hdl32e"] = "vlp16"
    rate_hz: float = Field(10.0, gt=0.0)
    range_m: float = 100.0
    range_noise_std_m: float | None = Field(None, description="default: Table 3.5 accuracy")
    record_every: int = Field(10, ge=1, description="write every Nth scan to the log")


class ImuSpec(Frozen):
    """IMU on imu_link (Table 3.6): specific force including gravity, angular rate."""

    enabled: bool = True
    rate_hz: float = Field(100.0, gt=0.0)
    accel_noise_std_mps2: float | None = Field(None, description="default: Table 3.6")
    gyro_noise_std_radps: float | None = None


class CameraSpec(Frozen):
    enabled: bool = False
    rate_hz: float = 5.0
    width_px: int = 80
    height_px: int = 60
    fov_rad: float = 1.2


class LogSource(Frozen):
    """Messages recorded in a log (ROS 1 bag, rosbag2 folder or MCAP), re-based to sim time."""

    log: str = Field(description="path, relative to the project root or absolute")
    topic: str | None = Field(None, description="default: the only topic of a suitable type")
    time_offset_s: float = Field(0.0, description="sim time of the log's first message")


class ManualController(Frozen):
    """The manual agent (seed Sec. 5.1.2): Joy axes/buttons mapped to kart commands."""

    type: Literal["manual"] = "manual"
    mapping: str = Field("ps4", description="models/gokart/joy/<mapping>.yaml")
    source: LogSource
    period_s: float = 0.02


class CommandsController(Frozen):
    """Replays a command stream: AckermannDriveStamped, Twist or TwistStamped."""

    type: Literal["commands"] = "commands"
    source: LogSource
    period_s: float = 0.02
    speed_gain_per_s: float = Field(2.0, description="accel = gain * (v_cmd - v)")


class ScriptStep(Frozen):
    t_s: float = Field(ge=0.0)
    steering_rad: float = 0.0
    accel_mps2: float = 0.0
    brake_mps2: float = 0.0


class ScriptController(Frozen):
    """A fixed command timeline (for tests and crash scenarios)."""

    type: Literal["script"] = "script"
    steps: tuple[ScriptStep, ...] = Field(min_length=1)
    period_s: float = 0.02


class JoyDriverController(Frozen):
    """A scripted human: pure pursuit on the centreline, expressed as joystick messages
    through a mapping, so that the manual agent drives. Used to record joystick logs."""

    type: Literal["joy_driver"] = "joy_driver"
    mapping: str = "ps4"
    target_speed_mps: float = 5.0
    lookahead_m: float = 3.5
    lateral_offset_m: float = Field(0.0, description="drive this far left of the centreline")
    max_lateral_accel_mps2: float = 4.0
    period_s: float = 0.02


class MpccVehicle(Frozen):
    """The MPCC's bicycle model of the kart. Defaults are fitted to the simulated kart's
    steady-circle runs (benchmarks/fit_mpcc.py), not to the real ETH kart."""

    cog_x_m: float = Field(0.36, description="centre of gravity ahead of base_link (Table 3.2)")
    steer_gain: float = Field(0.86, description="yaw response per kinematic bicycle's: the "
                              "simulated kart turns 14% less at low speed (tyre creep)")
    cog_to_front_m: float = 0.769
    cog_to_rear_m: float = 0.437
    mass_per_yaw_inertia_per_m2: float = Field(2.65, description="m / Iz, 1/m^2")
    front_b: float = 9.0
    front_c: float = 1.2
    front_d_mps2: float = Field(3.2, description="peak front lateral force / total mass")
    rear_b: float = 9.7
    rear_c: float = 1.1
    rear_d_mps2: float = Field(5.6, description="peak rear lateral force / total mass")
    rolling_decel_mps2: float = 0.15
    air_drag_per_m: float = Field(0.004, description="drag deceleration = this * v^2")
    blend_min_mps: float = Field(1.0, description="below: kinematic model only")
    blend_max_mps: float = Field(3.0, description="above: dynamic model only")
    kinematic_relax_s: float = Field(0.1, gt=0.0)


class MpccWeights(Frozen):
    """Cost weights (runtime parameters of the solver: changing them compiles nothing)."""

    contouring: float = Field(0.1, description="per m^2 of lateral error")
    lag: float = Field(100.0, description="per m^2 of lag error")
    progress: float = Field(0.5, description="reward per m/s of progress speed")
    jerk: float = Field(0.001, description="per (m/s^3)^2")
    steer_rate: float = Field(0.5, description="per (rad/s)^2")
    slack: float = Field(100.0, description="per m and per m^2 of bound violation")


class MpccController(Frozen):
    """Model predictive contouring control (Liniger et al., REFERENCE.md) solved with CasADi.
    Obstacles and other karts narrow the track bounds along the predicted path."""

    type: Literal["mpcc"] = "mpcc"
    period_s: float = Field(0.05, description="control period = solver call period")
    horizon_steps: int = Field(30, ge=5, le=80)
    step_s: float = Field(0.05, gt=0.0, description="horizon step")
    rk4_substeps: int = Field(2, ge=1, le=8)
    state_topic: str = Field("odom", description="nav_msgs/Odometry the controller reads")
    max_speed_mps: float = Field(7.0, gt=0.0)
    max_accel_mps2: float = Field(3.0, gt=0.0)
    max_brake_mps2: float = Field(5.0, gt=0.0)
    max_lateral_accel_mps2: float = Field(3.5, gt=0.0, description="friction ellipse, lateral")
    max_steer_rate_radps: float = Field(1.2, gt=0.0, description="front-wheel angle rate")
    max_jerk_mps3: float = Field(40.0, gt=0.0)
    track_padding_m: float = Field(0.95, ge=0.0, description="kept from each track edge by the "
                                   "kart's centre line: half the kart's width plus a margin")
    obstacle_margin_m: float = Field(0.9, ge=0.0, description="kept from an obstacle's edge")
    front_check_m: float = Field(1.0, ge=0.0, description="a point this far ahead of the CoG "
                                 "keeps the bounds too, so the nose does not cut corners")
    kart_length_m: float = Field(1.9, gt=0.0, description="footprint of other karts")
    kart_width_m: float = Field(1.3, gt=0.0)
    max_iterations: int = Field(100, ge=1, description="a solve that hits this counts as "
                                "failed: the iteration cap, not wall time, so runs stay "
                                "deterministic")
    compile: bool = Field(True, description="generate C and compile it (cached on disk)")
    vehicle: MpccVehicle = MpccVehicle()
    weights: MpccWeights = MpccWeights()


Controller = Annotated[LinePidController | ManualController | CommandsController
                       | ScriptController | JoyDriverController | MpccController,
                       Field(discriminator="type")]
Model = Annotated[LineTrackerModel | GokartModel, Field(discriminator="kind")]


class Pose2D(Frozen):
    """Start pose of the line-sensor midpoint relative to the course start, course frame."""

    along_m: float = Field(0.0, ge=0.0, description="distance along the course from its start")
    lateral_m: float = Field(0.0, description="left of the line is positive")
    heading_rad: float = 0.0


class AgentSpec(Frozen):
    model: Model
    controller: Controller
    start: Pose2D = Pose2D()
    line_sensor: LineSensorSpec = LineSensorSpec()
    sonar: SonarSpec = SonarSpec()
    lidar: LidarSpec = LidarSpec()
    imu: ImuSpec = ImuSpec()
    camera: CameraSpec = CameraSpec()


# --- scenario ---------------------------------------------------------------------------------


class PhysicsSpec(Frozen):
    dt_s: float = Field(0.002, ge=1e-5, le=0.01)
    odom_rate_hz: float = Field(50.0, gt=0.0)


class MetricsSpec(Frozen):
    transient_s: float = Field(5.0, ge=0.0, description="start-up transient excluded from errors")
    lost_threshold_m: float = Field(0.021, gt=0.0, description="sensor range; beyond it = lost")
    settle_band_m: float = Field(0.002, gt=0.0)


class Criterion(Frozen):
    """A pass criterion on one metric; any combination of bounds."""

    max: float | None = None
    min: float | None = None
    equal: float | None = None


class Scenario(Frozen):
    name: str = Field(pattern=r"^[a-z0-9_]+$")
    description: str
    world: World
    agents: dict[str, AgentSpec] = Field(min_length=1)
    duration_s: float = Field(gt=0.0, le=3600.0)
    seed: int = Field(0, ge=0)
    physics: PhysicsSpec = PhysicsSpec()
    metrics: MetricsSpec = MetricsSpec()
    criteria: dict[str, Criterion] = {}
    tags: tuple[str, ...] = ()

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


def line_parts(scenario: Scenario, agent: str) -> tuple[LineLabWorld, LineTrackerModel]:
    """The line lab and the line tracker of a line-tracker scenario, or a SpecError."""
    world, model = scenario.world, scenario.agents[agent].model
    if not isinstance(world, LineLabWorld) or not isinstance(model, LineTrackerModel):
        raise SpecError(f"scenario {scenario.name}: agent {agent} is not a line tracker in a "
                        "line lab")
    return world, model
