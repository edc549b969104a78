"""The MPCC's prediction model: a dynamic bicycle with Pacejka lateral tyres, blended into a
kinematic bicycle at low speed (where the dynamic model is singular), integrated with RK4.

State x = [X, Y, psi, vx, vy, r, s, delta, a]: world position (m), heading (rad), body
velocities (m/s), yaw rate (rad/s), arc-length progress (m), mean front-wheel angle (rad) and
longitudinal acceleration command (m/s^2, negative = brake). Input u = [jerk (m/s^3), steering
rate (rad/s), progress speed vs (m/s), slack (m)]. Tyre forces are mass-normalised (m/s^2), as
in the ETH kart's MPC (REFERENCE.md).
"""

from __future__ import annotations

import casadi as ca

from kartci.mpcc.params import MpccVehicle

NX, NU = 9, 4
X, Y, PSI, VX, VY, R, S, DELTA, ACC = range(NX)
JERK, DDELTA, VS, SLACK = range(NU)


def continuous(x: ca.SX, u: ca.SX, v: MpccVehicle) -> ca.SX:
    """dx/dt of the blended bicycle model."""
    psi, vx, vy, r, acc = x[PSI], x[VX], x[VY], x[R], x[ACC]
    delta = v.steer_gain * x[DELTA]
    lf, lr = v.cog_to_front_m, v.cog_to_rear_m
    vx_s = ca.sqrt(vx * vx + 0.25)  # slip angles are undefined at standstill; smooth floor
    alpha_f = delta - ca.atan((vy + lf * r) / vx_s)
    alpha_r = -ca.atan((vy - lr * r) / vx_s)
    ff = v.front_d_mps2 * ca.sin(v.front_c * ca.atan(v.front_b * alpha_f))
    fr = v.rear_d_mps2 * ca.sin(v.rear_c * ca.atan(v.rear_b * alpha_r))
    drag = v.rolling_decel_mps2 * ca.tanh(vx) + v.air_drag_per_m * vx * vx
    brake = 0.5 * (acc - ca.sqrt(acc * acc + 0.01))  # smooth min(acc, 0)
    ax = acc - brake * (1 - ca.tanh(vx / 0.3)) - drag  # brakes stop the kart, never reverse it
    dyn_vy = ff * ca.cos(delta) + fr - vx * r
    dyn_r = v.mass_per_yaw_inertia_per_m2 * (lf * ff * ca.cos(delta) - lr * fr)
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
        ax + vy * r * w,
        w * dyn_vy + (1 - w) * kin_vy,
        w * dyn_r + (1 - w) * kin_r,
        u[VS],
        u[DDELTA],
        u[JERK],
    )


def discrete(v: MpccVehicle, step_s: float, substeps: int) -> ca.Function:
    """x_{k+1} = F(x_k, u_k): `substeps` RK4 steps over one horizon step."""
    x, u = ca.SX.sym("x", NX), ca.SX.sym("u", NU)
    h = step_s / substeps
    xk = x
    for _ in range(substeps):
        k1 = continuous(xk, u, v)
        k2 = continuous(xk + h / 2 * k1, u, v)
        k3 = continuous(xk + h / 2 * k2, u, v)
        k4 = continuous(xk + h * k3, u, v)
        xk = xk + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return ca.Function("F", [x, u], [xk])
