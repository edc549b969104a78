"""The kart's controllers as registered (entry points `kartci.controllers`): their parameter
models (the MPCC's: `mpcc.params`) and `Controller` entries; the implementations load on first
use (`drivers`, `mpcc.agent`), so a run without an MPCC never imports CasADi."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.core import Change, Controller, ControllerParams, Fault, Frozen, lazy
from kartci.core.params import Angle_rad, Duration_s, Length_m, Period_s
from kartci.robots.gokart.mpcc.params import MpccController
from kartci.scenario.models import LogSource


class ManualController(ControllerParams):
    """The manual agent (source document, Sec. 5.1.2): Joy axes/buttons mapped to kart commands."""

    type: Literal["manual"] = Field("manual", description="controller type: the manual agent")
    mapping: str = Field("ps4", description="joystick mapping: `gokart/joy/<mapping>.yaml` on "
                         "the project's model path (built in: ps4, g29; source document 000 "
                         "Sec. 5.1)")
    source: LogSource = Field(description="the recorded sensor_msgs/Joy stream to replay")
    period_s: Period_s = Field(0.02, description="control period, s: a whole multiple of "
                               "physics.dt_s")


class CommandsController(ControllerParams):
    """Replays a command stream (AckermannDriveStamped, Twist or TwistStamped) onto the
    robot's standard command topics (`ackermann_cmd`, `cmd_vel`)."""

    type: Literal["commands"] = Field("commands", description="controller type: replay "
                                      "recorded commands")
    source: LogSource = Field(description="the recorded command stream (AckermannDriveStamped, "
                              "Twist or TwistStamped)")
    period_s: Period_s = Field(0.02, description="control period, s: a whole multiple of "
                               "physics.dt_s")


class ScriptStep(Frozen):
    """One command of a script, held from `t_s` until the next step's time (source document 000 Sec.
    5.2 command format: steering-wheel angle, motor acceleration, brake deceleration)."""

    t_s: Duration_s = Field(description="sim time from which this command holds, s")
    steering_rad: Angle_rad = Field(0.0, description="steering-column (steering-wheel) angle, rad; "
                                    "positive turns left (Table 3.3 range -1.84 to 1.73)")
    accel_mps2: float = Field(0.0, ge=-100.0, le=100.0,
                              description="motor command as an acceleration, m/s^2")
    brake_mps2: float = Field(0.0, ge=-100.0, le=100.0,
                              description="brake command as a deceleration, m/s^2")


class ScriptController(ControllerParams):
    """A fixed command timeline (for tests and crash scenarios)."""

    type: Literal["script"] = Field("script", description="controller type: a fixed command "
                                    "timeline")
    steps: tuple[ScriptStep, ...] = Field(min_length=1, description="the commands, each from "
                                          "its t_s on; before the first, the first holds")
    period_s: Period_s = Field(0.02, description="control period, s: a whole multiple of "
                               "physics.dt_s")


class JoyDriverController(ControllerParams):
    """A scripted human: pure pursuit on the centreline, expressed as joystick messages
    through a mapping, so that the manual agent drives. Used to record joystick logs."""

    type: Literal["joy_driver"] = Field("joy_driver", description="controller type: a "
                                        "scripted human on a joystick")
    mapping: str = Field("ps4", description="joystick mapping the driver's Joy messages go "
                         "through: `gokart/joy/<mapping>.yaml` on the model path")
    target_speed_mps: float = Field(5.0, ge=-100.0, le=100.0, description="speed on straights, m/s")
    lookahead_m: Length_m = Field(3.5, description="pure-pursuit distance to the aim point on the "
                                  "centreline, m")
    lateral_offset_m: Length_m = Field(0.0, description="drive this far left of the centreline, m")
    max_lateral_accel_mps2: float = Field(4.0, ge=-100.0, le=100.0,
                                          description="cornering limit that sets the "
                                          "speed from the curvature ahead, m/s^2")
    period_s: Period_s = Field(0.02, description="control period, s: a whole multiple of "
                               "physics.dt_s")


KART = ("gokart",)

MANUAL = Controller("manual", ManualController,
                    lazy("kartci.robots.gokart.drivers:ManualAgent"), KART,
                    "a recorded joystick (sensor_msgs/Joy) through a mapping")
COMMANDS = Controller("commands", CommandsController,
                      lazy("kartci.robots.gokart.drivers:CommandsAgent"), KART,
                      "a recorded AckermannDriveStamped, Twist or TwistStamped stream")
SCRIPT = Controller("script", ScriptController, lazy("kartci.robots.gokart.drivers:ScriptAgent"),
                    KART, "a fixed command timeline")
JOY_DRIVER = Controller("joy_driver", JoyDriverController,
                        lazy("kartci.robots.gokart.drivers:JoyDriver"), KART,
                        "a scripted human: pure pursuit expressed as joystick messages")
MPCC = Controller("mpcc", MpccController, lazy("kartci.robots.gokart.mpcc.agent:MpccAgent"),
                  KART, "model predictive contouring control (CasADi / Ipopt)",
                  fit=lazy("kartci.robots.gokart.mpcc.fit:fit_log"),
                  faults=(Fault("progress_weight_x0.7", "the progress reward at 70 % (a "
                                "mistuned cost: a slower line)",
                                (Change.scale("weights.progress", 0.7),)),))
