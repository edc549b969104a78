"""The kart's faults (`kartci faults`): what a regression in its drivetrain, steering, brakes,
tyres or sensors looks like, each through a parameter the simulation reads (params.py). The
sensor faults act where a node reads the sensor (the kart's own controllers drive from its
ground-truth odometry); an external stack that reads the IMU is not seen as a reader.

Not declared, for want of a parameter the simulation reads: sensor delays and mount offsets
(the mounts are the URDF's frames)."""

from __future__ import annotations

from kartci.core import Change, Fault

SENSOR_READERS = ("localization", "obstacle_detector")  # the node types that read the sensors

FAULTS = (
    Fault("motor_power_x0.5", "both rear motors give half their power (a derated inverter)",
          (Change.scale("model.motor_power_w", 0.5),)),
    Fault("wheel_torque_x0.7", "70 % of the peak wheel torque (a current limit set low)",
          (Change.scale("model.wheel_torque_limit_nm", 0.7),)),
    Fault("mass_+50pct", "50 % more mass (ballast, a heavier driver; inertia unchanged)",
          (Change.scale("model.mass_kg", 1.5),)),
    Fault("steering_rate_0.6", "steering column slews at 0.6 rad/s (a weak steering motor)",
          (Change.to("model.steering_rate_radps", 0.6),)),
    Fault("steering_offset_0.05", "the steering column's centre 0.05 rad (2.9 deg) off (a "
          "miscalibrated encoder)", (Change.to("model.steering_offset_rad", 0.05),)),
    Fault("command_delay_0.05", "commands reach the actuators 50 ms late (a congested bus)",
          (Change.to("model.command_delay_s", 0.05),)),
    Fault("brake_x0.5", "half the brake deceleration (worn pads)",
          (Change.scale("model.max_brake_mps2", 0.5),)),
    Fault("tyre_friction_0.8", "tyres at 0.8 of their friction (cold or worn tyres)",
          (Change.to("model.tire_friction", 0.8),)),
    Fault("imu_noise_x10", "IMU noise of a poorly mounted, vibrating unit: 0.5 m/s^2 and "
          "0.05 rad/s, 1 sigma", (Change.to("sensors.imu.accel_noise_std_mps2", 0.5),
                                  Change.to("sensors.imu.gyro_noise_std_radps", 0.05)),
          when=("sensors.imu.enabled",), read_by=SENSOR_READERS),
    Fault("gyro_bias", "a constant gyro bias of 0.02 rad/s, 1 sigma per axis (uncalibrated)",
          (Change.to("sensors.imu.gyro_bias_std_radps", 0.02),),
          when=("sensors.imu.enabled",), read_by=SENSOR_READERS),
    Fault("lidar_dropout_0.3", "30 % of the lidar's returns lost (a dirty window)",
          (Change.to("sensors.lidar.dropout_prob", 0.3),), when=("sensors.lidar.enabled",),
          read_by=SENSOR_READERS),
    Fault("wheel_slip_0.05", "wheel odometry off by 5 %, 1 sigma (worn tyres, spin-up)",
          (Change.to("sensors.wheels.slip_std", 0.05),), read_by=SENSOR_READERS),
)
