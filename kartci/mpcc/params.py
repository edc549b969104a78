"""The MPCC's parameters: its prediction model, cost weights and limits."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.spec.models import ControllerParams, Frozen


class MpccVehicle(Frozen):
    """The MPCC's bicycle model of the kart. Defaults are fitted to the simulated kart's
    steady-circle runs (benchmarks/fit_mpcc.py), not to the real ETH kart."""

    cog_x_m: float = Field(0.36, description="centre of gravity ahead of base_link, m "
                           "(cog_j, Table 3.2)")
    steer_gain: float = Field(0.86, description="yaw response per kinematic bicycle's "
                              "(dimensionless): the simulated kart turns 14% less at low speed "
                              "(tyre creep)")
    cog_to_front_m: float = Field(0.769, description="centre of gravity to front axle, m "
                                  "(fitted; REFERENCE.md: ETH wheelbase 1.19 m)")
    cog_to_rear_m: float = Field(0.437, description="centre of gravity to rear axle, m (fitted; "
                                 "REFERENCE.md: CoM 0.46 m ahead of the rear axle)")
    mass_per_yaw_inertia_per_m2: float = Field(2.65, description="m / Iz, 1/m^2")
    front_b: float = Field(9.0, description="Pacejka stiffness factor B of the front tyre, 1/rad: "
                           "F = D sin(C atan(B alpha)) (REFERENCE.md: ETH B = 9)")
    front_c: float = Field(1.2, description="Pacejka shape factor C of the front tyre "
                           "(dimensionless; REFERENCE.md: ETH C = 1)")
    front_d_mps2: float = Field(3.2, description="peak front lateral force / total mass, m/s^2 "
                                "(Pacejka D, mass-normalised as in the ETH MPC, REFERENCE.md)")
    rear_b: float = Field(9.7, description="Pacejka stiffness factor B of the rear tyre, 1/rad "
                          "(REFERENCE.md: ETH B = 5.2)")
    rear_c: float = Field(1.1, description="Pacejka shape factor C of the rear tyre "
                          "(dimensionless; REFERENCE.md: ETH C = 1.1)")
    rear_d_mps2: float = Field(5.6, description="peak rear lateral force / total mass, m/s^2 "
                               "(Pacejka D)")
    rolling_decel_mps2: float = Field(0.15, description="rolling resistance as a constant "
                                      "deceleration, m/s^2")
    air_drag_per_m: float = Field(0.004, description="drag deceleration = this * v^2, 1/m")
    blend_min_mps: float = Field(1.0, description="below this speed, m/s: kinematic model only")
    blend_max_mps: float = Field(3.0, description="above this speed, m/s: dynamic model only")
    kinematic_relax_s: float = Field(0.1, gt=0.0, description="time constant with which the "
                                     "kinematic model's lateral speed and yaw rate relax to "
                                     "their no-slip values, s")


class MpccWeights(Frozen):
    """Cost weights (runtime parameters of the solver: changing them compiles nothing)."""

    contouring: float = Field(0.1, description="cost per m^2 of contouring (lateral) error "
                              "(Liniger et al., REFERENCE.md)")
    lag: float = Field(100.0, description="cost per m^2 of lag error")
    progress: float = Field(0.5, description="reward per m/s of progress speed")
    jerk: float = Field(0.001, description="cost per (m/s^3)^2 of longitudinal jerk")
    steer_rate: float = Field(0.5, description="cost per (rad/s)^2 of front-wheel angle rate")
    slack: float = Field(100.0, description="cost per m and per m^2 of track-bound violation "
                         "(soft constraints)")


class MpccController(ControllerParams):
    """Model predictive contouring control (Liniger et al., REFERENCE.md) solved with CasADi.
    Obstacles and other karts narrow the track bounds along the predicted path."""

    type: Literal["mpcc"] = Field("mpcc", description="controller type: model predictive "
                                  "contouring control")
    period_s: float = Field(0.05, description="control period = solver call period, s: a whole "
                            "multiple of physics.dt_s")
    horizon_steps: int = Field(30, ge=5, le=80, description="prediction horizon N, steps "
                               "(REFERENCE.md: N = 30 at 0.05 s measured; ETH: N = 31)")
    step_s: float = Field(0.05, gt=0.0, description="horizon step, s")
    rk4_substeps: int = Field(2, ge=1, le=8, description="RK4 integration steps per horizon "
                              "step")
    state_topic: str = Field("odom", description="nav_msgs/Odometry topic the controller reads "
                             "(relative: in the agent's namespace); `localization/odom`: "
                             "drive on the localization node's estimate")
    obstacles_from: Literal["ground_truth", "perception"] = Field(
        "ground_truth", description="where obstacles come from: `ground_truth` (the world's "
        "boxes on /kartci/obstacles, other karts' odometry) or `perception` (the "
        "obstacle_detector node's detections, static and moving)")
    detections_topic: str = Field("obstacle_detector/detections", description="the "
                                  "vision_msgs/Detection3DArray read with `perception`")
    max_speed_mps: float = Field(7.0, gt=0.0, description="speed limit, m/s (soft; REFERENCE.md: "
                                 "ETH MPCC limit 10 m/s)")
    max_accel_mps2: float = Field(3.0, gt=0.0, description="longitudinal acceleration limit, "
                                  "m/s^2 (REFERENCE.md: ETH MPCC limit 5 m/s^2)")
    max_brake_mps2: float = Field(5.0, gt=0.0, description="braking deceleration limit, m/s^2")
    max_lateral_accel_mps2: float = Field(3.5, gt=0.0, description="friction ellipse, lateral, "
                                          "m/s^2 (REFERENCE.md: ETH MPCC limit 6.25 m/s^2)")
    max_steer_rate_radps: float = Field(1.2, gt=0.0, description="front-wheel angle rate limit, "
                                        "rad/s")
    max_jerk_mps3: float = Field(40.0, gt=0.0, description="longitudinal jerk limit, m/s^3")
    track_padding_m: float = Field(0.95, ge=0.0, description="kept from each track edge by the "
                                   "kart's centre line, m: half the kart's width plus a margin "
                                   "(REFERENCE.md: ETH padding 0.5 m)")
    obstacle_margin_m: float = Field(0.9, ge=0.0, description="kept from an obstacle's edge, m")
    front_check_m: float = Field(1.0, ge=0.0, description="a point this far ahead of the CoG, "
                                 "m, keeps the bounds too, so the nose does not cut corners")
    kart_length_m: float = Field(1.9, gt=0.0, description="footprint length of other karts, m "
                                 "(Table 3.1: vehicle length 2.07 m)")
    kart_width_m: float = Field(1.3, gt=0.0, description="footprint width of other karts, m")
    max_iterations: int = Field(100, ge=1, description="a solve that hits this counts as "
                                "failed: the iteration cap, not wall time, so runs stay "
                                "deterministic")
    compile: bool = Field(True, description="generate C and compile it (cached on disk)")
    vehicle: MpccVehicle = Field(MpccVehicle(), description="the prediction model's "
                                 "parameters (changing them recompiles the solver)")
    weights: MpccWeights = Field(MpccWeights(), description="cost weights (runtime "
                                 "parameters: changing them compiles nothing)")
