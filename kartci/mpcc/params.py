"""The MPCC's parameters: its prediction model, cost weights and limits."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from kartci.spec.models import ControllerParams, Frozen


class MpccVehicle(Frozen):
    """The MPCC's bicycle model of the kart. Defaults are fitted to the simulated kart's
    steady-circle runs (benchmarks/fit_mpcc.py), not to the real ETH kart."""

    cog_x_m: float = Field(0.36, description="centre of gravity ahead of base_link (Table 3.2)")
    steer_gain: float = Field(0.86, description="yaw response per kinematic bicycle's: the "
                              "simulated kart turns 14% less at low speed (tyre creep)")
    cog_to_front_m: float = 0.769
    cog_to_rear_m: float = 0.437
    mass_per_yaw_inertia_per_m2: float = Field(2.65, description="m / Iz, 1/m^2")
    front_b: float = 9.0
    front_c: float = 1.2
    front_d_mps2: float = Field(3.2, description="peak front lateral force / total mass")
    rear_b: float = 9.7
    rear_c: float = 1.1
    rear_d_mps2: float = Field(5.6, description="peak rear lateral force / total mass")
    rolling_decel_mps2: float = 0.15
    air_drag_per_m: float = Field(0.004, description="drag deceleration = this * v^2")
    blend_min_mps: float = Field(1.0, description="below: kinematic model only")
    blend_max_mps: float = Field(3.0, description="above: dynamic model only")
    kinematic_relax_s: float = Field(0.1, gt=0.0)


class MpccWeights(Frozen):
    """Cost weights (runtime parameters of the solver: changing them compiles nothing)."""

    contouring: float = Field(0.1, description="per m^2 of lateral error")
    lag: float = Field(100.0, description="per m^2 of lag error")
    progress: float = Field(0.5, description="reward per m/s of progress speed")
    jerk: float = Field(0.001, description="per (m/s^3)^2")
    steer_rate: float = Field(0.5, description="per (rad/s)^2")
    slack: float = Field(100.0, description="per m and per m^2 of bound violation")


class MpccController(ControllerParams):
    """Model predictive contouring control (Liniger et al., REFERENCE.md) solved with CasADi.
    Obstacles and other karts narrow the track bounds along the predicted path."""

    type: Literal["mpcc"] = "mpcc"
    period_s: float = Field(0.05, description="control period = solver call period")
    horizon_steps: int = Field(30, ge=5, le=80)
    step_s: float = Field(0.05, gt=0.0, description="horizon step")
    rk4_substeps: int = Field(2, ge=1, le=8)
    state_topic: str = Field("odom", description="nav_msgs/Odometry the controller reads")
    max_speed_mps: float = Field(7.0, gt=0.0)
    max_accel_mps2: float = Field(3.0, gt=0.0)
    max_brake_mps2: float = Field(5.0, gt=0.0)
    max_lateral_accel_mps2: float = Field(3.5, gt=0.0, description="friction ellipse, lateral")
    max_steer_rate_radps: float = Field(1.2, gt=0.0, description="front-wheel angle rate")
    max_jerk_mps3: float = Field(40.0, gt=0.0)
    track_padding_m: float = Field(0.95, ge=0.0, description="kept from each track edge by the "
                                   "kart's centre line: half the kart's width plus a margin")
    obstacle_margin_m: float = Field(0.9, ge=0.0, description="kept from an obstacle's edge")
    front_check_m: float = Field(1.0, ge=0.0, description="a point this far ahead of the CoG "
                                 "keeps the bounds too, so the nose does not cut corners")
    kart_length_m: float = Field(1.9, gt=0.0, description="footprint of other karts")
    kart_width_m: float = Field(1.3, gt=0.0)
    max_iterations: int = Field(100, ge=1, description="a solve that hits this counts as "
                                "failed: the iteration cap, not wall time, so runs stay "
                                "deterministic")
    compile: bool = Field(True, description="generate C and compile it (cached on disk)")
    vehicle: MpccVehicle = MpccVehicle()
    weights: MpccWeights = MpccWeights()
