"""Parameters of kartci's built-in controllers other than the MPCC."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field

from kartci.core import ControllerParams, Frozen
from kartci.scenario.models import LogSource


class LinePidController(ControllerParams):
    """P / PI tracking controller of the seed's TestSensor.cc (Eq. 6.13, wheel-speed law)."""

    type: Literal["line_pid"] = Field("line_pid", description="controller type: the seed's "
                                      "P / PI line tracker")
    kp: float = Field(50.0, ge=-1e6, le=1e6,
                      description="proportional gain, 1/(m s): u2 = Kp * (-d) + Ki * "
                      "integral (seed 001 Sec. 6.5; Sec. 7.1 tried Kp 5-150, Sec. 7.2 Kp 50)")
    ki: float = Field(0.0, ge=-1e6, le=1e6,
                      description="integral gain; like TestSensor.cc, the integral grows by "
                      "0.01 * Ki * (-d) per control step (seed 001 Sec. 7.3: Ki 0.001)")
    period_s: float = Field(0.01, gt=0.0, le=3600.0,
                            description="control period, s: a whole multiple of "
                            "physics.dt_s (seed 001 Sec. 7.2: 0.01 s keeps the circle stable)")
    v1_mps: float = Field(0.1, ge=-100.0, le=100.0,
                          description="forward speed command v1, m/s (seed 001 Sec. 7: "
                          "0.1 m/s; the annex code's default is 0.05)")
    stop_range_m: float = Field(0.1, ge=-1e4, le=1e4,
                                description="stop when the sonar reads less than this, m "
                                "(seed 001 annex, TestSensor.cc)")
    slope_m: float = Field(0.0254, ge=-1e4, le=1e4,
                           description="d = slope_m * y + offset_m, m per unit of "
                           "camera difference y (Eq. 6.13)")
    offset_m: float = Field(-0.000091365, ge=-1e4, le=1e4,
                            description="offset of the linear sensor model, m "
                            "(Eq. 6.13)")
    half_track_m: float = Field(0.06, ge=-1e4, le=1e4,
                                description="lever in the annex wheel-speed law, m: "
                                "wL = (v1 - 0.06 u2) / r, wR = (v1 + 0.06 u2) / r")
    widened_range: bool = Field(False, description="Albert Costa's widened range (seed 001 "
                                "Sec. 6.3): outside +-0.008 m the camera sum, not the difference, "
                                "carries the offset, read with Eq. 6.15 out to +-0.021 m. Off: "
                                "the annex TestSensor.cc, which uses Eq. 6.13 alone")
    edge_left: float = Field(0.4582, ge=-1e6, le=1e6,
                             description="widened range: the left camera's output at "
                             "+0.008 m (output1 at maxdiff; kartci's sensor, `kartci "
                             "characterise`)")
    edge_right: float = Field(0.1704, ge=-1e6, le=1e6,
                              description="widened range: the right camera's output "
                              "at +0.008 m (the left's at -0.008 m, by symmetry)")
    wide_slope_m: float = Field(1.0 / 26.5472, ge=-1e4, le=1e4,
                                description="widened range: d = wide_slope_m * "
                                "(y - wide_intercept), m per unit of y (Eq. 6.15 inverted)")
    wide_intercept: float = Field(0.0134, ge=-1e6, le=1e6,
                                  description="widened range: Eq. 6.15's intercept")


class ManualController(ControllerParams):
    """The manual agent (seed Sec. 5.1.2): Joy axes/buttons mapped to kart commands."""

    type: Literal["manual"] = Field("manual", description="controller type: the manual agent")
    mapping: str = Field("ps4", description="joystick mapping: `gokart/joy/<mapping>.yaml` on "
                         "the project's model path (built in: ps4, g29; seed 000 Sec. 5.1)")
    source: LogSource = Field(description="the recorded sensor_msgs/Joy stream to replay")
    period_s: float = Field(0.02, gt=0.0, le=3600.0,
                            description="control period, s: a whole multiple of "
                            "physics.dt_s")


class CommandsController(ControllerParams):
    """Replays a command stream (AckermannDriveStamped, Twist or TwistStamped) onto the
    robot's standard command topics (`ackermann_cmd`, `cmd_vel`)."""

    type: Literal["commands"] = Field("commands", description="controller type: replay "
                                      "recorded commands")
    source: LogSource = Field(description="the recorded command stream (AckermannDriveStamped, "
                              "Twist or TwistStamped)")
    period_s: float = Field(0.02, gt=0.0, le=3600.0,
                            description="control period, s: a whole multiple of "
                            "physics.dt_s")


class ScriptStep(Frozen):
    """One command of a script, held from `t_s` until the next step's time (seed 000 Sec. 5.2
    command format: steering-wheel angle, motor acceleration, brake deceleration)."""

    t_s: float = Field(ge=0.0, le=3600.0, description="sim time from which this command holds, s")
    steering_rad: float = Field(0.0, ge=-math.tau, le=math.tau,
                                description="steering-column (steering-wheel) angle, rad; "
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
    period_s: float = Field(0.02, gt=0.0, le=3600.0,
                            description="control period, s: a whole multiple of "
                            "physics.dt_s")


class JoyDriverController(ControllerParams):
    """A scripted human: pure pursuit on the centreline, expressed as joystick messages
    through a mapping, so that the manual agent drives. Used to record joystick logs."""

    type: Literal["joy_driver"] = Field("joy_driver", description="controller type: a "
                                        "scripted human on a joystick")
    mapping: str = Field("ps4", description="joystick mapping the driver's Joy messages go "
                         "through: `gokart/joy/<mapping>.yaml` on the model path")
    target_speed_mps: float = Field(5.0, ge=-100.0, le=100.0, description="speed on straights, m/s")
    lookahead_m: float = Field(3.5, ge=-1e4, le=1e4,
                               description="pure-pursuit distance to the aim point on the "
                               "centreline, m")
    lateral_offset_m: float = Field(0.0, ge=-1e4, le=1e4,
                                    description="drive this far left of the centreline, m")
    max_lateral_accel_mps2: float = Field(4.0, ge=-100.0, le=100.0,
                                          description="cornering limit that sets the "
                                          "speed from the curvature ahead, m/s^2")
    period_s: float = Field(0.02, gt=0.0, le=3600.0,
                            description="control period, s: a whole multiple of "
                            "physics.dt_s")
