"""The MPCC's prediction model: a dynamic single-track (bicycle) model with Pacejka lateral tyres,
blended into a kinematic bicycle at low speed (where the dynamic model is singular), integrated
with RK4. Its parameters are the simulated kart's own (`SingleTrack.of`: one source of truth,
`models/gokart/params.yaml`), as in Liniger, Domahidi, Morari 2015.

State x = [X, Y, psi, vx, vy, r, s, delta, a]: world position (m), heading (rad), body
velocities (m/s), yaw rate (rad/s), arc-length progress (m), mean front-wheel angle (rad) and
longitudinal acceleration command (m/s^2, negative = brake). Input u = [jerk (m/s^3), steering
rate (rad/s), progress speed vs (m/s), slack (m)]. Tyre forces are mass-normalised (m/s^2), as
in the ETH kart's MPC (REFERENCE.md): an axle carrying a share of the mass gives that share
times D sin(C atan(B alpha)) per kg of the whole kart. Mirrored from the plant where it matters
for planning: the motors' power limit (drive at most 2 x motor power / (m v)), rolling resistance
and drag, and the floor's friction mu under each stage (`grip`): D = mu g, the plant's peak at
the static loads this model keeps (no load transfer, so the load sensitivity has no part).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import casadi as ca
from pydantic import Field

from kartci.core import Frozen
from kartci.robots.gokart.mpcc.params import MpccVehicle
from kartci.robots.gokart.params import (
    GRAVITY_MPS2,
    PDY1,
    GokartModel,
    Tyre,
    air_drag_per_m,
    axle_distance_m,
    rolling_decel_mps2,
)

NX, NU = 9, 4
DRIVEN_WHEELS = 2  # one motor per rear wheel (REFERENCE.md: two 2.8 kW motors)
X, Y, PSI, VX, VY, R, S, DELTA, ACC = range(NX)
JERK, DDELTA, VS, SLACK = range(NU)


class AxleCurve(Frozen):
    """One axle's lateral curve in the single-track model: F_y per kg of axle load =
    grip D sin(C atan(B alpha)), grip the floor's friction coefficient."""

    b: float = Field(gt=0.0, le=1e6, description="stiffness factor B, 1/rad")
    c: float = Field(gt=0.0, le=1e6, description="shape factor C (dimensionless)")
    d_mps2: float = Field(gt=0.0, le=100.0, description="peak force per kg of axle load on a "
                          "floor of friction 1, m/s^2: g pDy1, the plant's at the static load")

    @classmethod
    def of(cls, tyre: Tyre) -> AxleCurve:
        """The curve of a tyre at its static load (dfz = 0)."""
        return cls(b=tyre.b, c=tyre.c, d_mps2=GRAVITY_MPS2 * PDY1)


@dataclass(frozen=True)
class SingleTrack:
    """The kart as a single-track model: geometry, mass ratio, tyres and drag, all read from
    the robot's parameters."""

    lf_m: float  # centre of mass to front axle
    lr_m: float  # centre of mass to rear axle
    mass_per_yaw_inertia_per_m2: float
    front: AxleCurve
    rear: AxleCurve
    rolling_decel_mps2: float
    air_drag_per_m: float
    power_per_kg: float  # both motors' power over the mass, W/kg: the drive's power limit

    @classmethod
    def of(cls, model: GokartModel) -> SingleTrack:
        """The single-track model of a go-kart's parameters."""
        length, lr = axle_distance_m(model), model.cog_to_rear_axle_m
        return cls(length - lr, lr, model.mass_kg / model.yaw_inertia_kgm2,
                   AxleCurve.of(model.front_tyre), AxleCurve.of(model.rear_tyre),
                   rolling_decel_mps2(model), air_drag_per_m(model),
                   DRIVEN_WHEELS * model.motor_power_w / model.mass_kg)

    def key(self) -> str:
        """A stable text of every value, for the compiled solver's cache key."""
        return repr(sorted(asdict(self).items()))


def _tyre(t: AxleCurve, share: float, alpha: ca.SX, grip: ca.SX | float) -> ca.SX:
    return share * grip * t.d_mps2 * ca.sin(t.c * ca.atan(t.b * alpha))


def _smooth_min(a: ca.SX, b: ca.SX) -> ca.SX:
    return 0.5 * (a + b - ca.sqrt((a - b) ** 2 + 0.01))


def continuous(x: ca.SX, u: ca.SX, m: SingleTrack, v: MpccVehicle,
               grip: ca.SX | float = 1.0) -> ca.SX:
    """dx/dt of the blended bicycle model on a floor of friction coefficient `grip` (the
    floor's mu times the kart's `tire_friction`, as in the plant)."""
    psi, vx, vy, r, acc, delta = x[PSI], x[VX], x[VY], x[R], x[ACC], x[DELTA]
    lf, lr = m.lf_m, m.lr_m
    vx_s = ca.sqrt(vx * vx + 1.0)  # slip angles are undefined at standstill; smooth floor
    alpha_f = delta - ca.atan((vy + lf * r) / vx_s)
    alpha_r = -ca.atan((vy - lr * r) / vx_s)
    share_f, share_r = lr / (lf + lr), lf / (lf + lr)  # static axle loads: mass shares
    brake = 0.5 * (acc - ca.sqrt(acc * acc + 0.01))  # smooth min(acc, 0)
    # the motors' power limit, as in the plant: above the corner speed the drive gives at most
    # P / (m v) (vx floored: the torque limit is the command's own bound there)
    drive = _smooth_min(acc - brake, m.power_per_kg / ca.sqrt(vx * vx + 1.0))
    # friction circle as in the plant: the rear motors' drive force and the brakes on both
    # axles (per kg of axle load) leave sqrt(1 - (F_x / D)^2) of each axle's lateral grip
    long_f, long_r = -brake, drive / share_r + brake
    d_f, d_r = grip * m.front.d_mps2, grip * m.rear.d_mps2
    ff = _tyre(m.front, share_f, alpha_f, grip) * ca.sqrt(ca.fmax(1 - (long_f / d_f) ** 2, 0.01))
    fr = _tyre(m.rear, share_r, alpha_r, grip) * ca.sqrt(ca.fmax(1 - (long_r / d_r) ** 2, 0.01))
    drag = m.rolling_decel_mps2 * ca.tanh(vx / 0.3) + m.air_drag_per_m * vx * vx
    ax = drive + brake * ca.tanh(vx / 0.3) - drag  # brakes stop the kart, never reverse it
    dyn_vy = ff * ca.cos(delta) + fr - vx * r
    dyn_r = m.mass_per_yaw_inertia_per_m2 * (lf * ff * ca.cos(delta) - lr * fr)
    # kinematic bicycle: vy and r relax to their no-slip values
    r_kin = vx * ca.tan(delta) / (lf + lr)
    kin_vy = (lr * r_kin - vy) / v.kinematic_relax_s
    kin_r = (r_kin - r) / v.kinematic_relax_s
    mid, width = (v.blend_min_mps + v.blend_max_mps) / 2, (v.blend_max_mps - v.blend_min_mps)
    w = 0.5 * (1 + ca.tanh(4 * (vx - mid) / width))  # smooth: Newton steps need derivatives
    return ca.vertcat(
        vx * ca.cos(psi) - vy * ca.sin(psi),
        vx * ca.sin(psi) + vy * ca.cos(psi),
        r,
        ax + w * (vy * r - ff * ca.sin(delta)),
        w * dyn_vy + (1 - w) * kin_vy,
        w * dyn_r + (1 - w) * kin_r,
        u[VS],
        u[DDELTA],
        u[JERK],
    )


def discrete(m: SingleTrack, v: MpccVehicle, step_s: float, substeps: int) -> ca.Function:
    """x_{k+1} = F(x_k, u_k, grip): `substeps` RK4 steps over one horizon step on a floor
    of friction coefficient `grip`."""
    x, u, grip = ca.SX.sym("x", NX), ca.SX.sym("u", NU), ca.SX.sym("grip")
    h = step_s / substeps
    xk = x
    for _ in range(substeps):
        k1 = continuous(xk, u, m, v, grip)
        k2 = continuous(xk + h / 2 * k1, u, m, v, grip)
        k3 = continuous(xk + h / 2 * k2, u, m, v, grip)
        k4 = continuous(xk + h * k3, u, m, v, grip)
        xk = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function("F", [x, u, grip], [xk])
