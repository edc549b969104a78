"""The go-kart's parameters and sensors (source document 000, Tables 3.1-3.6); units in the key
names."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field

from kartci.core import Frozen, RobotParams
from kartci.scenario.models import Angle_rad, Length_m


class Tyre(Frozen):
    """One axle's tyres: Pacejka's magic formula for the lateral force (Pacejka, "Tire and
    Vehicle Dynamics"; the ETH kart's MPC, Liniger et al. 2015; REFERENCE.md),
    F_y = N g mu_peak sin(C atan(B alpha)), N the wheel's load in kg, alpha the slip angle in rad.

    The peak friction coefficient falls with load (Pacejka's load sensitivity, REFERENCE.md
    "Tyre load sensitivity"): mu_peak = mu (pDy1 + pDy2 dfz), dfz = (N - N0) / N0, N0 the wheel's
    static load and mu the floor's friction. pDy1 is 1 (`PDY1`): a wheel at its static load has
    the floor's mu exactly, a more loaded one less. B and C are ETH's; their D (10 m/s^2 on any
    load) is replaced by mu_peak g, so no axle's grip exceeds mu times its load."""

    b: float = Field(gt=0.0, le=1e6, description="stiffness factor B, 1/rad")
    c: float = Field(gt=0.0, le=1e6, description="shape factor C (dimensionless)")
    p_dy2: float = Field(-0.1, gt=-1.0, le=0.0,
                         description="load sensitivity pDy2 of the peak friction coefficient "
                         "(dimensionless, per unit dfz): mu_peak = mu (1 + pDy2 dfz). An "
                         "assumption: no Magic Formula fit of the kart's tyres is published; "
                         "-0.1 (10 % less mu at twice the static load) is of the order of "
                         "published passenger-car fits")


PDY1 = 1.0  # pDy1, dimensionless: a wheel at its static load has exactly the floor's mu


class GokartModel(RobotParams):
    """The ETH go-kart (source document 000, Tables 3.1, 3.2, 3.4); limits from REFERENCE.md."""

    kind: Literal["gokart"] = Field("gokart", description="robot kind: the ETH go-kart")
    variant: Literal["bumblebee", "herbie"] = Field("bumblebee", description="which of the two "
                                                    "karts: sensor mounts (Table 3.4) and IMU "
                                                    "(Table 3.6) differ")
    urdf: str = Field("bumblebee.urdf", description="the kart's URDF: absolute, or relative to "
                      "gokart/ on the project's model path")
    rear_wheel_radius_m: float = Field(0.127, ge=-1e4, le=1e4,
                                       description="rear tyre radius, m (Table 3.1)")
    front_wheel_radius_m: float = Field(0.117, ge=-1e4, le=1e4,
                                        description="front tyre radius, m (Table 3.1)")
    wheel_torque_limit_nm: float = Field(95.0, ge=0.0, le=1e5,
                                         description="peak torque per rear wheel (one motor "
                                         "each), N m: the motor curve's constant-torque part "
                                         "(REFERENCE.md; Rimo Sinus ION data sheet: 95 Nm per "
                                         "wheel)")
    motor_power_w: float = Field(2800.0, gt=0.0, le=1e7,
                                 description="power per rear motor, W: the motor curve's "
                                 "constant-power part above the corner speed power / torque "
                                 "(REFERENCE.md; Rimo Sinus ION data sheet: 2 x 2.8 kW, the rated "
                                 "power; no short-time peak is published, so none is modelled)")
    max_speed_mps: float = Field(10.0, ge=-100.0, le=100.0,
                                 description="top forward speed of the rear-wheel speed "
                                 "reference, m/s (REFERENCE.md: ETH MPCC limit 10 m/s)")
    max_accel_mps2: float = Field(5.0, ge=-100.0, le=100.0,
                                  description="largest motor acceleration command, m/s^2 "
                                  "(REFERENCE.md: ETH longitudinal limit 5 m/s^2)")
    max_brake_mps2: float = Field(8.0, ge=-100.0, le=100.0,
                                  description="largest brake deceleration command, m/s^2")
    reverse_speed_mps: float = Field(2.0, ge=-100.0, le=100.0, description="top reverse speed, m/s")
    steering: Literal["measured", "ackermann"] = Field("measured", description="front-wheel "
                                                       "angles from the column angle: "
                                                       "`measured` map (Eq. 3.4/3.5, Table "
                                                       "3.3) or ideal `ackermann` (Eq. 3.1/3.2)")
    steering_limit_rad: tuple[Angle_rad, Angle_rad] = Field((-1.845, 1.732), description="steering-"
                                                    "column angle range (min, max), rad "
                                                    "(measured in Table 3.3)")
    steering_rate_radps: float = Field(4.0, ge=-1e3, le=1e3,
                                       description="column angle slew rate, rad/s")
    steering_offset_rad: float = Field(0.0, ge=-0.5, le=0.5, description="column angle added "
                                       "to every steering command: a miscalibrated centre, rad "
                                       "(0: none)")
    command_delay_s: float = Field(0.0, ge=0.0, le=1.0, description="dead time between a "
                                   "command and the actuators taking it, s (rounded to physics "
                                   "steps; 0: the next step)")
    wheelbase_m: float = Field(1.27, ge=-1e4, le=1e4,
                               description="l of Eq. 3.1/3.2, m (Ackermann option)")
    track_m: float = Field(0.94, ge=-1e4, le=1e4,
                           description="w of Eq. 3.1/3.2, m (Ackermann option)")
    tire_friction: float = Field(1.0, ge=0.0, le=10.0,
                                 description="tyre friction factor (dimensionless): "
                                 "scales the floor's or zone's friction coefficient mu that "
                                 "bounds the tyres' peak force")
    mass_kg: float = Field(283.4, gt=0.0, le=1e5, description="total mass, kg (source document "
                           "000 Table 3.1, Bumblebee); the URDF's link masses add up to it")
    cog_to_rear_axle_m: float = Field(0.46, gt=0.0, le=1e4,
                                      description="centre of mass ahead of the "
                                      "rear axle, m (REFERENCE.md: ETH kart, 0.46 m)")
    cog_height_m: float = Field(0.24, gt=0.0, le=1e4,
                                description="centre of mass above the floor, m "
                                "(source document 000 Table 3.1): the load transfer's lever")
    yaw_inertia_kgm2: float = Field(20.0, gt=0.0, le=1e5, description="yaw moment of inertia about "
                                    "the centre of mass, kg m^2 (REFERENCE.md: ETH kart, about "
                                    "20 kg m^2)")
    front_tyre: Tyre = Field(Tyre(b=9.0, c=1.0), description="front tyres "
                             "(REFERENCE.md: ETH B 9, C 1; pDy2 an assumption)")
    rear_tyre: Tyre = Field(Tyre(b=5.2, c=1.1), description="rear tyres "
                            "(REFERENCE.md: ETH B 5.2, C 1.1, the only rear-tyre figures "
                            "published for the kart; pDy2 an assumption). With these the kart "
                            "oversteers: `critical_speed_mps`")
    rolling_resistance_coeff: float = Field(0.015, ge=0.0, le=1.0,
                                            description="rolling resistance per unit normal "
                                            "load (dimensionless), drivetrain drag included: "
                                            "an assumption (kart slicks on smooth concrete, "
                                            "0.01-0.02; the earlier 0.15 m/s^2 / g)")
    drag_area_m2: float = Field(0.54, ge=0.0, le=100.0,
                                description="aerodynamic drag area Cd A, m^2: an assumption (a "
                                "kart with its seat and sensor mast, Cd 0.9 x 0.6 m^2 frontal "
                                "area; no measurement of the ETH kart is published)")
    air_density_kgpm3: float = Field(1.2, gt=0.0, le=10.0,
                                     description="air density, kg/m^3 (indoor air at 20 C, "
                                     "1.204)")
    long_slip_stiffness: float = Field(15.0, gt=0.0, le=1e4,
                                       description="longitudinal slip stiffness per unit "
                                       "normal load (dimensionless): F_x = this x slip ratio x "
                                       "N g below the grip limit; sets the wheel speeds a drive "
                                       "or brake force shows (an assumption: the order of "
                                       "pneumatic tyres, no figure for the kart's Dunlop SL1)")
    long_grip_ratio: float = Field(1.0, gt=0.0, le=10.0,
                                   description="longitudinal over lateral peak grip "
                                   "(dimensionless): the friction ellipse's axes ratio; 1, a "
                                   "circle, as no source gives the kart's")
    speed_gain_per_s: float = Field(2.0, gt=0.0, le=1e4, description="drive-by-wire speed loop for "
                                    "ackermann_cmd and cmd_vel, 1/s: accel = gain * (v_cmd - v)")
    wheel_xy_m: tuple[tuple[Length_m, Length_m], ...] = Field(
        ((-0.077, 0.5625), (-0.077, -0.5625), (1.129, 0.47), (1.129, -0.47)),
        description="rl, rr, fl, fr wheel centres (x, y) in base_link, m (Table 3.2)")


class LidarSpec(Frozen):
    """Velodyne VLP-16 or HDL-32E (Table 3.5) on velodyne_link."""

    enabled: bool = Field(False, description="simulate the lidar and record its point clouds "
                          "(`velodyne_points`, sensor_msgs/PointCloud2)")
    model: Literal["vlp16", "hdl32e"] = Field("vlp16", description="Velodyne model: channels, "
                                              "vertical field of view and resolutions of "
                                              "Table 3.5")
    rate_hz: float = Field(10.0, gt=0.0, le=1e5,
                           description="rotation rate, Hz (Table 3.5: 5-20 Hz)")
    range_m: float = Field(100.0, ge=-1e4, le=1e4,
                           description="measurement range, m (Table 3.5: 100 m)")
    range_noise_std_m: float | None = Field(None, ge=-1e4, le=1e4,
                                            description="range noise, 1 sigma, m; "
                                            "default: the Table 3.5 accuracy (3 cm VLP-16, 2 cm "
                                            "HDL-32E)")
    record_every: int = Field(10, ge=1, le=1_000_000,
                              description="write every Nth scan to the log (the "
                              "others still reach the nodes and controller that read them)")
    dropout_prob: float = Field(0.0, ge=0.0, lt=1.0, description="probability that a return "
                                "is lost (no echo: dark or specular surfaces), per beam, "
                                "seeded")
    motion_distortion: bool = Field(False, description="sample each azimuth at its own time "
                                    "in the revolution (the kart moves while the head spins, "
                                    "points stay in their own momentary sensor frame): what "
                                    "deskewing removes; off: every beam at the scan's stamp")


class ImuSpec(Frozen):
    """IMU on imu_link (Table 3.6): specific force including gravity, angular rate."""

    enabled: bool = Field(True, description="simulate the IMU (`imu`, sensor_msgs/Imu)")
    rate_hz: float = Field(100.0, gt=0.0, le=1e5,
                           description="output rate, Hz (Table 3.6: 1-1000 Hz "
                           "IRIMU-V2, 10-480 Hz 3DM-GX5)")
    accel_noise_std_mps2: float | None = Field(None, ge=-100.0, le=100.0,
                                               description="accelerometer noise, 1 sigma, "
                                               "m/s^2; default: Table 3.6 accuracy x the "
                                               "default 8 g full scale of the variant's IMU")
    gyro_noise_std_radps: float | None = Field(None, ge=-1e3, le=1e3,
                                               description="gyroscope noise, 1 sigma, "
                                               "rad/s; default: Table 3.6 accuracy x the "
                                               "default full scale of the variant's IMU")
    accel_bias_std_mps2: float = Field(0.0, ge=0.0, le=100.0,
                                       description="constant accelerometer bias, "
                                       "1 sigma per axis, m/s^2: drawn once per run, seeded")
    gyro_bias_std_radps: float = Field(0.0, ge=0.0, le=1e3, description="constant gyroscope bias, "
                                       "1 sigma per axis, rad/s: drawn once per run, seeded")
    accel_bias_walk_mps2_per_sqrt_s: float = Field(0.0, ge=0.0, le=1e3,
                                                   description="accelerometer "
                                                   "bias random walk, m/s^2 per sqrt(s)")
    gyro_bias_walk_radps_per_sqrt_s: float = Field(0.0, ge=0.0, le=1e3,
                                                   description="gyroscope bias "
                                                   "random walk, rad/s per sqrt(s)")


class WheelSpec(Frozen):
    """What `joint_states` reports of the wheels: their spin, which the physics already lets
    slip; `slip_std` adds the slip a rigid-tyre simulation lacks (tyre creep, spinning up)."""

    slip_std: float = Field(0.0, ge=0.0, lt=0.5, description="relative wheel-speed error "
                            "(dimensionless, 1 sigma), a first-order Gauss-Markov process per "
                            "wheel, seeded: reported = true * (1 + slip)")
    slip_corr_s: float = Field(0.5, gt=0.0, le=3600.0,
                               description="correlation time of the slip, s")


class CameraSpec(Frozen):
    """An RGB camera on camera_link (Table 3.4); the source document's cameras are not calibrated
    (Sec. 3.4.3), so these are small defaults for a cheap image."""

    enabled: bool = Field(False, description="render images (`camera/image_raw`, "
                          "sensor_msgs/Image)")
    rate_hz: float = Field(5.0, ge=0.0, le=1e5, description="frame rate, Hz")
    width_px: int = Field(80, ge=1, le=8192, description="image width, pixels")
    height_px: int = Field(60, ge=1, le=8192, description="image height, pixels")
    fov_rad: float = Field(1.2, ge=-math.tau, le=math.tau,
                           description="horizontal field of view, rad")


class KartSensors(Frozen):
    """The kart's sensors, each at its Table 3.4 mount."""

    lidar: LidarSpec = Field(LidarSpec(), description="Velodyne lidar on velodyne_link "
                             "(Tables 3.4, 3.5)")
    imu: ImuSpec = Field(ImuSpec(), description="IMU on imu_link (Tables 3.4, 3.6)")
    camera: CameraSpec = Field(CameraSpec(), description="camera on camera_link (Table 3.4)")
    wheels: WheelSpec = Field(WheelSpec(), description="wheel odometry errors in "
                              "`joint_states`")


def axle_distance_m(model: GokartModel) -> float:
    """Distance between the rear and front axles (Table 3.2), m."""
    return model.wheel_xy_m[2][0] - model.wheel_xy_m[0][0]


GRAVITY_MPS2 = 9.81


def rolling_decel_mps2(model: GokartModel) -> float:
    """Rolling resistance as a deceleration, m/s^2: c_rr g, whatever the mass."""
    return model.rolling_resistance_coeff * GRAVITY_MPS2


def air_drag_per_m(model: GokartModel) -> float:
    """Aerodynamic deceleration per speed squared, 1/m: rho Cd A / (2 m)."""
    return 0.5 * model.air_density_kgpm3 * model.drag_area_m2 / model.mass_kg


def cog_x_m(model: GokartModel) -> float:
    """The centre of mass ahead of base_link, m: the rear axle (Table 3.2) plus
    `cog_to_rear_axle_m`."""
    return model.wheel_xy_m[0][0] + model.cog_to_rear_axle_m

