"""The localization node's parameters; units in the key names."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field

from kartci.core import Frozen, NodeParams
from kartci.core.params import Angle_rad, Count, Distance_m, Length_m, Period_s, Size_m


class InitialGuess(Frozen):
    """Where the filter starts: a pose on the track plus a deliberate error (what a person
    placing the kart by eye gets wrong), never the simulator's truth."""

    along_m: Distance_m = Field(0.0, description="the guess is the track centreline's pose "
                                "this far along the track, m")
    error_xy_m: tuple[Length_m, Length_m] = Field((0.3, -0.2), description="error added to the "
                                            "guessed position (x, y), m, map frame")
    error_yaw_rad: Angle_rad = Field(0.03, description="error added to the guessed heading, rad")
    std_xy_m: Size_m = Field(0.5, description="the filter's initial position sigma, m")
    std_yaw_rad: float = Field(0.1, gt=0.0, le=math.tau,
                               description="the filter's initial heading sigma, "
                               "rad")


class LocalizationParams(NodeParams):
    """Lidar + IMU + wheel-odometry localization against the world's map."""

    period_s: Period_s = Field(0.02, description="filter output period, s: "
                               "`localization/odom` and tf at this rate")
    map: str = Field("winti/hall_map.ply", description="the map (PLY, world frame, made by "
                     "`kartci map`): relative to the world folders, or absolute")
    registration: bool = Field(True, description="register scans against the map; off: dead "
                               "reckoning on wheels and gyro only (a regression to compare)")
    deskew: bool = Field(True, description="motion-compensate each scan with the filter's "
                         "twist before registration")
    method: Literal["GICP", "VGICP", "ICP", "PLANE_ICP"] = Field(
        "GICP", description="small_gicp registration type: GICP (the default: ~1 cm per "
        "VLP-16 scan, ~30 ms on one core), VGICP (voxelized: ~9 ms, ~2 cm, and it lost the "
        "kart among unmapped boxes in perception_obstacles), ICP, PLANE_ICP; "
        "benchmarks/bench_localization.py measures them")
    vgicp_voxel_m: Size_m = Field(1.0, description="voxel size of the map's Gaussians "
                                  "for VGICP, m")
    scan_voxel_m: Size_m = Field(0.3, description="voxel size the scan is thinned to "
                                 "before registration, m")
    map_voxel_m: Size_m = Field(0.2, description="voxel size the map is thinned to, m")
    max_correspondence_m: Size_m = Field(1.0, description="largest point pair "
                                         "registration matches, m")
    max_iterations: Count = Field(20, description="registration iterations per scan")
    min_range_m: Distance_m = Field(1.0, description="returns closer than this are "
                                    "dropped (the kart itself, the driver), m")
    min_inlier_ratio: float = Field(0.5, ge=0.0, le=1.0, description="a registration with "
                                    "fewer scan points matched is not used")
    registration_std_m: Size_m = Field(0.01, description="position sigma of one "
                                       "registration in the filter, m")
    registration_std_rad: float = Field(0.003, gt=0.0, le=math.tau,
                                        description="heading sigma of one "
                                        "registration in the filter, rad")
    gate_chi2: float = Field(16.27, gt=0.0, le=1e6,
                             description="Mahalanobis gate on a registration "
                             "(chi^2, 3 dof; 16.27 is 99.9%)")
    relocalize_after: Count = Field(5, description="this many gated-out but mutually "
                                    "consistent registrations in a row reset the filter onto "
                                    "them (recovery from a kidnap)")
    wheel_speed_std_mps: float = Field(0.05, gt=0.0, le=100.0,
                                       description="wheel speed sigma in the "
                                       "prediction, m/s, plus 5% of the speed for slip")
    gyro_std_radps: float = Field(0.02, gt=0.0, le=1e3, description="gyro sigma in the prediction, "
                                  "rad/s")
    gyro_bias_walk_radps_per_sqrt_s: float = Field(0.001, gt=0.0, le=1e3,
                                                   description="the filter's "
                                                   "model of the gyro bias random walk")
    accel_std_mps2: float = Field(0.8, gt=0.0, le=100.0,
                                  description="accelerometer sigma per sample in "
                                  "the lateral-velocity prediction, m/s^2 (the kart's IRIMU-V2: "
                                  "1% of its 8 g range, Table 3.6)")
    sensor_height_m: Length_m = Field(1.154, description="velodyne_link above base_link, m, "
                                      "until /tf_static says (the registration's initial z)")
    cloud_every: Count = Field(10, description="publish every Nth deskewed scan "
                               "(`localization/cloud`) to the log")
    initial: InitialGuess = Field(InitialGuess(), description="the initial guess")
