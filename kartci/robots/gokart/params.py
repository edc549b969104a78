"""The go-kart's parameters and sensors (seed 000, Tables 3.1-3.6); units in the key names."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.spec.models import Frozen, RobotParams


class GokartModel(RobotParams):
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
    speed_gain_per_s: float = Field(2.0, gt=0.0, description="drive-by-wire speed loop for "
                                    "ackermann_cmd and cmd_vel: accel = gain * (v_cmd - v)")
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


class KartSensors(Frozen):
    """The kart's sensors, each at its Table 3.4 mount."""

    lidar: LidarSpec = LidarSpec()
    imu: ImuSpec = ImuSpec()
    camera: CameraSpec = CameraSpec()
