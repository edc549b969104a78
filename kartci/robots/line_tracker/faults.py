"""The line tracker's faults (`kartci faults`): its motors, wheels and line sensor, each
through a parameter the simulation reads (params.py).

Not declared, for want of such a parameter: a sensor mount offset (`sensor_point_x_m` also
moves the metrics' lever, so it is not a fault of the robot alone) and sensor dropout."""

from __future__ import annotations

from kartci.core import Change, Fault

FAULTS = (
    Fault("wheel_lag_x2", "wheels respond twice as slowly (a sluggish motor driver)",
          (Change.scale("model.wheel_time_constant_s", 2.0),)),
    Fault("wheel_speed_limit_x0.5", "wheels saturate at half their speed (a low battery)",
          (Change.scale("model.wheel_speed_limit_radps", 0.5),)),
    Fault("wheel_torque_x0.7", "70 % of the wheel motors' torque",
          (Change.scale("model.wheel_torque_limit_nm", 0.7),)),
    Fault("tyre_friction_0.8", "tyres at 0.8 of their friction (dusty wheels)",
          (Change.to("model.tire_friction", 0.8),)),
    Fault("line_sensor_noise_x10", "ten times the line sensor's luminance noise",
          (Change.scale("sensors.line_sensor.noise_std", 10.0),)),
    Fault("line_sensor_delay_1", "the line sensor's reading one frame late",
          (Change.add("sensors.line_sensor.latency_frames", 1),)),
)
