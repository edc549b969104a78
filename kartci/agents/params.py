"""Parameters of kartci's built-in controllers other than the MPCC."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.spec.models import ControllerParams, Frozen, LogSource


class LinePidController(ControllerParams):
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


class ManualController(ControllerParams):
    """The manual agent (seed Sec. 5.1.2): Joy axes/buttons mapped to kart commands."""

    type: Literal["manual"] = "manual"
    mapping: str = Field("ps4", description="models/gokart/joy/<mapping>.yaml")
    source: LogSource
    period_s: float = 0.02


class CommandsController(ControllerParams):
    """Replays a command stream (AckermannDriveStamped, Twist or TwistStamped) onto the
    robot's standard command topics (`ackermann_cmd`, `cmd_vel`)."""

    type: Literal["commands"] = "commands"
    source: LogSource
    period_s: float = 0.02


class ScriptStep(Frozen):
    t_s: float = Field(ge=0.0)
    steering_rad: float = 0.0
    accel_mps2: float = 0.0
    brake_mps2: float = 0.0


class ScriptController(ControllerParams):
    """A fixed command timeline (for tests and crash scenarios)."""

    type: Literal["script"] = "script"
    steps: tuple[ScriptStep, ...] = Field(min_length=1)
    period_s: float = 0.02


class JoyDriverController(ControllerParams):
    """A scripted human: pure pursuit on the centreline, expressed as joystick messages
    through a mapping, so that the manual agent drives. Used to record joystick logs."""

    type: Literal["joy_driver"] = "joy_driver"
    mapping: str = "ps4"
    target_speed_mps: float = 5.0
    lookahead_m: float = 3.5
    lateral_offset_m: float = Field(0.0, description="drive this far left of the centreline")
    max_lateral_accel_mps2: float = 4.0
    period_s: float = 0.02
