"""The MPCC's parameters: its prediction model, cost weights and limits."""

from __future__ import annotations

from enum import StrEnum
from typing import Literal

from pydantic import Field

from kartci.core import ControllerParams, Frozen
from kartci.core.params import Count, Distance_m, Gain, Period_s, Size_m


class MpccMethod(StrEnum):
    """How each control step's optimal control problem is solved."""

    IPOPT = "ipopt"  # the full NLP to convergence with Ipopt + MUMPS: the reference
    RTI = "rti"  # real-time iterations: a fixed number of QPs (SQP steps) per control step


class QpSolver(StrEnum):
    """The QP solver of the RTI mode (CasADi conic plugins)."""

    HPIPM = "hpipm"  # interior point with a Riccati recursion: exploits the OCP structure
    OSQP = "osqp"  # ADMM on the sparse QP
    QPOASES = "qpoases"  # active set (its sparse Schur-complement variant)
    DAQP = "daqp"  # dual active set (dense)


class MpccVehicle(Frozen):
    """Modelling choices of the MPCC's bicycle model. Its physical parameters (geometry, mass,
    inertia, tyres, drag) are the robot's own (`models/gokart/params.yaml`), not copied here."""

    blend_min_mps: float = Field(1.0, ge=-100.0, le=100.0,
                                 description="below this speed, m/s: kinematic model only")
    blend_max_mps: float = Field(3.0, ge=-100.0, le=100.0,
                                 description="above this speed, m/s: dynamic model only")
    kinematic_relax_s: Period_s = Field(0.1, description="time constant with which the "
                                        "kinematic model's lateral speed and yaw rate relax to "
                                        "their no-slip values, s")


class MpccWeights(Frozen):
    """Cost weights (runtime parameters of the solver: changing them compiles nothing)."""

    contouring: Gain = Field(0.1, description="cost per m^2 of contouring (lateral) error "
                             "(Liniger et al., REFERENCE.md)")
    lag: Gain = Field(100.0, description="cost per m^2 of lag error")
    progress: Gain = Field(0.5, description="reward per m/s of progress speed")
    jerk: Gain = Field(0.001, description="cost per (m/s^3)^2 of longitudinal jerk")
    steer_rate: Gain = Field(0.5, description="cost per (rad/s)^2 of front-wheel angle rate")
    slack: Gain = Field(100.0, description="cost per m and per m^2 of track-bound violation "
                        "(soft constraints)")


class MpccRecovery(Frozen):
    """When the kart is out of control and how it recovers: brake straight (column centred)
    until it slides no more, then re-plan from scratch."""

    sideslip_deg: float = Field(20.0, gt=0.0, le=180.0, description="sideslip (heading vs "
                                "direction of travel at the centre of mass) above this while "
                                "faster than `moving_mps` is a loss of control, deg")
    yaw_rate_excess_radps: float = Field(1.0, gt=0.0, le=100.0, description="a yaw rate this "
                                         "far beyond the kinematic one (v tan(delta) / l) is a "
                                         "loss of control, rad/s")
    moving_mps: float = Field(2.0, ge=0.0, le=100.0, description="sideslip and yaw rate are "
                              "judged above this speed, m/s")
    stall_steps: int = Field(40, ge=1, le=100_000, description="control steps with progress "
                             "below `stall_mps` (after the first plan) that count as stalled")
    stall_mps: float = Field(0.1, ge=0.0, le=100.0, description="progress along the track "
                             "slower than this is no progress, m/s")
    recovered_deg: float = Field(5.0, gt=0.0, le=180.0, description="recovery ends when the "
                                 "sideslip is below this (or the kart is slower than "
                                 "`moving_mps`), deg")


class MpccController(ControllerParams):
    """Model predictive contouring control (Liniger et al., REFERENCE.md) solved with CasADi.
    Obstacles and other karts narrow the track bounds along the predicted path."""

    type: Literal["mpcc"] = Field("mpcc", description="controller type: model predictive "
                                  "contouring control")
    period_s: Period_s = Field(0.05, description="control period = solver call period, s: a whole "
                               "multiple of physics.dt_s")
    horizon_steps: int = Field(30, ge=5, le=80, description="prediction horizon N, steps "
                               "(REFERENCE.md: N = 30 at 0.05 s measured; ETH: N = 31)")
    step_s: Period_s = Field(0.075, description="horizon step, s: 30 x 0.075 s = 2.25 s, "
                             "long enough to brake from 10 m/s for the hall's hairpin (ETH: 31 x "
                             "0.1 s)")
    rk4_substeps: int = Field(3, ge=1, le=8, description="RK4 integration steps per horizon "
                              "step (0.025 s each: the yaw dynamics of a 20 kg m^2 kart are "
                              "fast at low speed)")
    state_topic: str = Field("odom", description="nav_msgs/Odometry topic the controller reads "
                             "(relative: in the agent's namespace); `localization/odom`: "
                             "drive on the localization node's estimate")
    obstacles_from: Literal["ground_truth", "perception"] = Field(
        "ground_truth", description="where obstacles come from: `ground_truth` (the world's "
        "boxes on /kartci/obstacles, other karts' odometry) or `perception` (the "
        "obstacle_detector node's detections, static and moving)")
    detections_topic: str = Field("obstacle_detector/detections", description="the "
                                  "vision_msgs/Detection3DArray read with `perception`")
    max_speed_mps: float = Field(10.0, gt=0.0, le=100.0,
                                 description="speed limit, m/s (soft; REFERENCE.md: "
                                 "ETH MPCC limit 10 m/s)")
    max_accel_mps2: float = Field(5.0, gt=0.0, le=100.0,
                                  description="longitudinal acceleration limit, "
                                  "m/s^2 (REFERENCE.md: ETH MPCC limit 5 m/s^2)")
    max_brake_mps2: float = Field(5.0, gt=0.0, le=100.0,
                                  description="braking deceleration limit, m/s^2")
    max_lateral_accel_mps2: float = Field(6.25, gt=0.0, le=100.0,
                                          description="friction ellipse, lateral, "
                                          "m/s^2 (REFERENCE.md: ETH MPCC limit 6.25 m/s^2)")
    max_steer_rate_radps: float = Field(1.2, gt=0.0, le=1e3,
                                        description="front-wheel angle rate limit, "
                                        "rad/s")
    max_jerk_mps3: Size_m = Field(40.0, description="longitudinal jerk limit, m/s^3")
    track_margin_m: Distance_m = Field(0.5,
                                  description="kept between each track edge and the kart's "
                                  "outline, m: the padding of the kart's centre line is the "
                                  "outline's half width (0.69 m, the rear wheels) plus this "
                                  "(REFERENCE.md: ETH padding 0.5 m)")
    passing_margin_m: Distance_m = Field(0.1,
                                    description="kept between a track edge and the kart's "
                                    "outline beside a kart it passes, m: "
                                    "`track_margin_m` gives way to clearing them (the hall's "
                                    "4 m track leaves 0.81 m either side of the centre line "
                                    "with the full margin, too little to pass a 1.38 m kart)")
    obstacle_margin_m: Distance_m = Field(0.9,
                                     description="kept from an obstacle's edge, m")
    front_check_m: Distance_m = Field(1.0,
                                 description="a point this far ahead of the CoG, "
                                 "m, keeps the bounds too, so the nose does not cut corners")
    max_column_rad: float = Field(0.65, gt=0.0, le=2.0,
                                  description="steering-column angle range, +- rad. ETH's "
                                  "MPCC uses +-0.5 rad (REFERENCE.md): a mean front-wheel angle "
                                  "of 0.176 rad, a 6.8 m kinematic turning radius, where the "
                                  "hall track's tightest turn has a 2.46 m centre-line radius "
                                  "(s = 58 m; 0.81 m of room either side after the padding). "
                                  "At 0.5 the kart laps alone (mpcc_lap) but runs wide into "
                                  "the slower kart in multi_agent's east hairpin; 0.65 (0.224 "
                                  "rad, 5.3 m) is the smallest of 0.5 / 0.65 / 0.8 that drives "
                                  "every shipped MPCC scenario without a collision")
    recovery: MpccRecovery = Field(MpccRecovery(), description="loss-of-control detection "
                                   "and the recovery behaviour")
    method: MpccMethod = Field(MpccMethod.RTI, description="`rti`: real-time iterations, "
                               "`sqp_iterations` QPs per step with `qp_solver` (laps every "
                               "shipped scenario within 1 % of Ipopt at a third of its solve "
                               "time); `ipopt`: the NLP to convergence every step, the "
                               "reference")
    qp_solver: QpSolver = Field(QpSolver.HPIPM, description="the RTI mode's QP solver")
    sqp_iterations: int = Field(3, ge=1, le=20, description="RTI: SQP iterations (QPs) per "
                                "control step, a fixed count so runs stay deterministic. "
                                "Three: one QP per step solves in 0.43x the time and passes "
                                "every criterion, but its less converged plans spread 9 metrics "
                                "of 4 scenarios past their tolerances over nanometre start "
                                "moves (2 with three; docs/explain/speed.md)")
    sqp_cold_iterations: int = Field(10, ge=1, le=100, description="RTI: SQP iterations of a "
                                     "solve without a previous plan (the first, and after a "
                                     "failure)")
    max_iterations: Count = Field(100, description="a solve that hits this counts as "
                                  "failed (Ipopt iterations; in RTI the QP solver's own cap): "
                                  "an iteration cap, not wall time, so runs stay deterministic")
    compile: bool = Field(True, description="generate C and compile it (cached on disk)")
    vehicle: MpccVehicle = Field(MpccVehicle(), description="the prediction model's "
                                 "parameters (changing them recompiles the solver)")
    weights: MpccWeights = Field(MpccWeights(), description="cost weights (runtime "
                                 "parameters: changing them compiles nothing)")
