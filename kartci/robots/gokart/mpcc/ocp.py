"""The MPCC optimal-control problem as one parametric NLP (multiple shooting).

Everything that varies between solves is a parameter or a bound: the measured state (bounds on
x_0), the track linearised at each stage's predicted progress, the lateral bounds (narrowed by
obstacles), the cost weights, the lateral-acceleration limit, and the speed, input and
steering limits. The compiled solver therefore depends only on the horizon and the vehicle
model, and one build serves every track, obstacle layout and tuning.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from kartci.robots.gokart.mpcc.model import (
    ACC,
    DDELTA,
    DELTA,
    JERK,
    NU,
    NX,
    PSI,
    SLACK,
    VS,
    VX,
    R,
    S,
    SingleTrack,
    X,
    Y,
    discrete,
)
from kartci.robots.gokart.mpcc.params import MpccController, MpccWeights

STAGE_PARAMS = 9  # x_ref, y_ref, cos(heading), sin(heading), s_ref, lateral lo/hi, s_max, grip
N_WEIGHTS = 6
LIMITS_FRICTION = 0.9  # ETH's acceleration limits hold on concrete (REFERENCE.md: mu about 0.9)
CONSTRAINTS_PER_STAGE = NX + 7


@dataclass(frozen=True)
class Layout:
    """Where stage k's state and input sit in the decision vector w = [x0 u0 x1 u1 ... xN]."""

    n: int

    @property
    def size(self) -> int:
        """Length of the decision vector w."""
        return self.n * (NX + NU) + NX

    def x(self, k: int) -> slice:
        """Stage k's state in w."""
        start = k * (NX + NU)
        return slice(start, start + NX)

    def u(self, k: int) -> slice:
        """Stage k's input in w."""
        start = k * (NX + NU) + NX
        return slice(start, start + NU)

    def _stages(self, w: np.ndarray) -> np.ndarray:
        """Stages 0..N-1 of w as rows [x_k u_k] (a view)."""
        return w[:self.n * (NX + NU)].reshape(self.n, NX + NU)

    def states(self, w: np.ndarray) -> np.ndarray:
        """The N + 1 states in w, one row per stage."""
        return np.vstack([self._stages(w)[:, :NX], w[None, self.x(self.n)]])

    def inputs(self, w: np.ndarray) -> np.ndarray:
        """The N inputs in w, one row per stage."""
        return self._stages(w)[:, NX:].copy()

    def pack(self, states: np.ndarray, inputs: np.ndarray) -> np.ndarray:
        """The decision vector w of N + 1 states and N inputs (rows)."""
        w = np.empty(self.size)
        rows = self._stages(w)
        rows[:, :NX], rows[:, NX:] = states[:self.n], inputs
        w[self.x(self.n)] = states[self.n]
        return w


def weights_vector(w: MpccWeights) -> list[float]:
    """The cost weights in the order the NLP's parameter vector holds them."""
    return [w.contouring, w.lag, w.progress, w.jerk, w.steer_rate, w.slack]


def build(spec: MpccController, model: SingleTrack) -> tuple[dict[str, ca.MX], Layout]:
    """The NLP {x, p, f, g}; g <= 0 for the path constraints, g == 0 for the dynamics."""
    n = spec.horizon_steps
    lay = Layout(n)
    f_step = discrete(model, spec.vehicle, spec.step_s, spec.rk4_substeps)
    # MX with one shared F: the generated C holds F and its derivatives once, not N times,
    # which keeps the compile short
    w = ca.MX.sym("w", lay.size)
    p = ca.MX.sym("p", N_WEIGHTS + 4 + STAGE_PARAMS * n)
    qc, ql, qv, rj, rd, qs = (p[i] for i in range(N_WEIGHTS))
    a_lat, a_long = p[N_WEIGHTS], p[N_WEIGHTS + 1]  # friction ellipse, m/s^2
    front = p[N_WEIGHTS + 2]  # a second point this far ahead of the CoG keeps the bounds too
    v_max = p[N_WEIGHTS + 3]  # soft: a hard bound plus the jerk limit can make x_0 infeasible
    cost = ca.MX(0)
    g = []

    def stage_ref(k: int) -> list[ca.MX]:  # parameters of stage k = 1..N
        base = N_WEIGHTS + 4 + STAGE_PARAMS * (k - 1)
        return [p[base + i] for i in range(STAGE_PARAMS)]

    def errors(xk: ca.MX, ref: list[ca.MX], ahead: ca.MX | float = 0.0) -> tuple[ca.MX, ca.MX]:
        xr, yr, c, s, s_ref = ref[:5]
        dx = xk[X] + ahead * ca.cos(xk[PSI]) - xr
        dy = xk[Y] + ahead * ca.sin(xk[PSI]) - yr
        return c * dy - s * dx, c * dx + s * dy - (xk[S] - s_ref)  # lateral (left +), lag

    # stage by stage, the dynamics to x_{k+1}, then the path constraints of x_k with the
    # slack in u_k: the order structure-exploiting solvers (fatrop) expect
    for k in range(n):
        xk, uk = w[lay.x(k)], w[lay.u(k)]
        slack = uk[SLACK]
        # the floor under stage k (stage 1's for the measured state) scales the tyres' grip
        grip = stage_ref(max(k, 1))[8]
        g.append(w[lay.x(k + 1)] - f_step(xk, uk, grip))
        if k > 0:
            ref = stage_ref(k)
            lateral, lag = errors(xk, ref)
            lo, hi, s_max = ref[5:8]
            # ETH's acceleration limits hold on concrete; a slipperier floor shrinks the
            # ellipse with its friction
            ellipse = ca.fmin(grip / LIMITS_FRICTION, 1.0)
            lateral_front, _ = errors(xk, ref, front)
            cost += qc * lateral**2 + ql * lag**2 + qs * (slack + slack**2)
            g += [lateral - hi - slack, lo - lateral - slack, xk[S] - s_max - slack,
                  lateral_front - hi - slack, lo - lateral_front - slack,
                  xk[VX] - v_max - slack,
                  (xk[VX] * xk[R] / (a_lat * ellipse)) ** 2
                  + (xk[ACC] / (a_long * ellipse)) ** 2 - 1
                  - slack]
        cost += -qv * uk[VS] + rj * uk[JERK] ** 2 + rd * uk[DDELTA] ** 2
    lateral, lag = errors(w[lay.x(n)], stage_ref(n))
    cost += qc * lateral**2 + ql * lag**2
    return {"x": w, "p": p, "f": cost, "g": ca.vertcat(*g)}, lay


def equality(n: int) -> list[bool]:
    """Which constraints are equalities (the dynamics), in the order `build` stacks them."""
    path = [False] * (CONSTRAINTS_PER_STAGE - NX)
    return [True] * NX + ([True] * NX + path) * (n - 1)


def constraint_bounds(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Bounds (lbg, ubg) on g: 0 for the dynamics, at most 0 for the path constraints."""
    eq = np.array(equality(n))
    return np.where(eq, 0.0, -np.inf), np.zeros(len(eq))


def variable_bounds(spec: MpccController, lay: Layout, x0: np.ndarray,
                    max_delta_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """Box bounds: x_0 fixed to the measurement; speed, steering, acceleration and input
    limits on every later stage."""
    x_lo = np.full(NX, -np.inf)
    x_hi = np.full(NX, np.inf)
    x_lo[VX], x_hi[VX] = 0.0, spec.max_speed_mps + 2.0  # the limit itself is soft (g)
    x_lo[DELTA], x_hi[DELTA] = -max_delta_rad, max_delta_rad
    x_lo[ACC], x_hi[ACC] = -spec.max_brake_mps2, spec.max_accel_mps2
    u_lo = np.array([-spec.max_jerk_mps3, -spec.max_steer_rate_radps, 0.0, 0.0])
    u_hi = np.array([spec.max_jerk_mps3, spec.max_steer_rate_radps,
                     spec.max_speed_mps * 1.2, np.inf])
    lbw = lay.pack(np.vstack([x0, np.tile(x_lo, (lay.n, 1))]), np.tile(u_lo, (lay.n, 1)))
    ubw = lay.pack(np.vstack([x0, np.tile(x_hi, (lay.n, 1))]), np.tile(u_hi, (lay.n, 1)))
    ubw[lay.u(0).start + SLACK] = 0.0  # stage 0 has no path constraints to relax
    return lbw, ubw


