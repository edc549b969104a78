"""The line tracker's controllers as registered (entry points `kartci.controllers`): their
parameter models and `Controller` entries; the implementations load on first use."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.core import Change, Controller, ControllerParams, Fault, lazy
from kartci.core.params import Gain, Length_m, Period_s


class LinePidController(ControllerParams):
    """P / PI tracking controller of the source document's TestSensor.cc (Eq. 6.13, wheel-speed
    law)."""

    type: Literal["line_pid"] = Field("line_pid", description="controller type: the source "
                                      "document's P / PI line tracker")
    kp: Gain = Field(50.0, description="proportional gain, 1/(m s): u2 = Kp * (-d) + Ki * "
                     "integral (source document 001 Sec. 6.5; Sec. 7.1 tried Kp 5-150, Sec. 7.2 "
                     "Kp 50)")
    ki: Gain = Field(0.0, description="integral gain; like TestSensor.cc, the integral grows by "
                     "0.01 * Ki * (-d) per control step (source document 001 Sec. 7.3: Ki 0.001)")
    period_s: Period_s = Field(0.01, description="control period, s: a whole multiple of "
                               "physics.dt_s (source document 001 Sec. 7.2: 0.01 s keeps the "
                               "circle stable)")
    v1_mps: float = Field(0.1, ge=-100.0, le=100.0,
                          description="forward speed command v1, m/s (source document 001 Sec. 7: "
                          "0.1 m/s; the annex code's default is 0.05)")
    stop_range_m: Length_m = Field(0.1, description="stop when the sonar reads less than this, m "
                                   "(source document 001 annex, TestSensor.cc)")
    slope_m: Length_m = Field(0.0254, description="d = slope_m * y + offset_m, m per unit of "
                              "camera difference y (Eq. 6.13)")
    offset_m: Length_m = Field(-0.000091365, description="offset of the linear sensor model, m "
                               "(Eq. 6.13)")
    half_track_m: Length_m = Field(0.06, description="lever in the annex wheel-speed law, m: "
                                   "wL = (v1 - 0.06 u2) / r, wR = (v1 + 0.06 u2) / r")
    widened_range: bool = Field(False, description="Albert Costa's widened range (source "
                                "document 001 Sec. 6.3): outside +-0.008 m the camera sum, not "
                                "the difference, carries the offset, read with Eq. 6.15 out to "
                                "+-0.021 m. Off: the annex TestSensor.cc, which uses Eq. 6.13 "
                                "alone")
    edge_left: Gain = Field(0.4582, description="widened range: the left camera's output at "
                            "+0.008 m (output1 at maxdiff; kartci's sensor, `kartci "
                            "characterise`)")
    edge_right: Gain = Field(0.1704, description="widened range: the right camera's output "
                             "at +0.008 m (the left's at -0.008 m, by symmetry)")
    wide_slope_m: Length_m = Field(1.0 / 26.5472, description="widened range: d = wide_slope_m * "
                                   "(y - wide_intercept), m per unit of y (Eq. 6.15 inverted)")
    wide_intercept: Gain = Field(0.0134, description="widened range: Eq. 6.15's intercept")


LINE_PID = Controller("line_pid", LinePidController,
                      lazy("kartci.robots.line_tracker.line_pid:LinePid"), ("line_tracker",),
                      "the source document's P / PI line-tracking controller",
                      faults=(Fault("kp_x0.7", "proportional gain at 70 % (a mistuned loop)",
                                    (Change.scale("kp", 0.7),)),
                              Fault("ki_x0.7", "integral gain at 70 % (PI only)",
                                    (Change.scale("ki", 0.7),))))
