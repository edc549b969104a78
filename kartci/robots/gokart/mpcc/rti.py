"""Real-time iterations (RTI) of SQP for the MPCC (Diehl's RTI scheme, as in acados and
Liniger's kart MPCC): per control step a fixed number of QPs, each the NLP linearised around the
current iterate (the last solution shifted by one step), with the cost's own Hessian (the
contouring and lag errors are linear in the state, so the Gauss-Newton Hessian is exact for the
cost; constraint curvature is dropped) plus a small Levenberg-Marquardt term. The QP keeps the
multiple-shooting structure that HPIPM's Riccati recursion exploits."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from kartci.robots.gokart.mpcc.direct import CompiledFunction, OcpQp, Stages
from kartci.robots.gokart.mpcc.model import NU, NX
from kartci.robots.gokart.mpcc.ocp import CONSTRAINTS_PER_STAGE, equality
from kartci.robots.gokart.mpcc.params import MpccController, QpSolver

REGULARISATION = 1e-2  # Levenberg-Marquardt term: states without a cost (vy, r) keep H > 0
QP_TOL = 1e-6  # the QP solvers' residual tolerance (cost, dynamics, bounds, complementarity)


class RtiStatus(StrEnum):
    """The outcome of one control step's real-time iterations."""

    SOLVED = "Solved"  # every QP solved
    SOLVED_EARLY = "Solved_early"  # a later QP failed: the iterate of the QPs before it
    QP_FAILED = "QP_failed"  # the first QP failed (iteration cap, infeasible, NaN step)


@dataclass(frozen=True)
class Iterate:
    """The iterate after a control step's QPs, its cost and how the QPs went."""

    w: np.ndarray
    cost: float
    status: RtiStatus
    qp_iterations: int

    @property
    def ok(self) -> bool:
        """Whether at least the first QP solved and the iterate is usable."""
        return self.status in (RtiStatus.SOLVED, RtiStatus.SOLVED_EARLY)


def linearisation(nlp: dict[str, ca.MX], n: int) -> ca.Function:
    """(w, p) -> (g, dg/dw, f, df/dw, d2f/dw2 + regularisation): what each QP is built from; the
    function that is generated as C and compiled. The dynamics rows are negated, F - x_{k+1},
    the sign HPIPM's interface expects (its -I on x_{k+1})."""
    w, p = nlp["x"], nlp["p"]
    g = nlp["g"] * ca.DM(np.where(equality(n), -1.0, 1.0))
    hess, grad = ca.hessian(nlp["f"], w)
    hess = hess + REGULARISATION * ca.MX.eye(w.numel())
    return ca.Function("rti_lin", [w, p],
                       [g, ca.jacobian(g, w), nlp["f"], grad, hess],
                       ["w", "p"], ["g", "jac_g", "f", "grad_f", "hess_f"])


def qp_options(spec: MpccController) -> dict[str, Any]:
    """The QP solver's options: the OCP structure for HPIPM, an iteration cap for all."""
    n, cap = spec.horizon_steps, spec.max_iterations
    common: dict[str, Any] = {"error_on_fail": False, "print_problem": False}
    if spec.qp_solver is QpSolver.HPIPM:
        path = CONSTRAINTS_PER_STAGE - NX
        return {**common, "N": n, "nx": [NX] * (n + 1), "nu": [NU] * n + [0],
                "ng": [0] + [path] * (n - 1) + [0],
                # every variable is boxed (infinite bounds become 1e8), so the default
                # relative tolerances are rarely met: absolute residual limits instead
                "hpipm": {"iter_max": cap, "mode": "speed", "res_g_max": QP_TOL,
                          "res_b_max": QP_TOL, "res_d_max": QP_TOL, "res_m_max": QP_TOL}}
    if spec.qp_solver is QpSolver.OSQP:
        return {**common, "osqp": {"verbose": False, "max_iter": cap * 40, "eps_abs": QP_TOL,
                                   "eps_rel": QP_TOL, "polish": True}}
    if spec.qp_solver is QpSolver.QPOASES:
        return {**common, "printLevel": "none", "sparse": True, "nWSR": cap * 10}
    return {**common, "daqp": {"iter_limit": cap * 10}}


def stages(n: int) -> Stages:
    """The OCP's stage sizes as `ocp.build` stacks them: no path constraints on x_0 (it is
    fixed) nor on x_N, no input at stage N."""
    return Stages(n, [NX] * (n + 1), [NU] * n + [0],
                  [0] + [CONSTRAINTS_PER_STAGE - NX] * (n - 1) + [0])


class ConicQp:
    """A QP solver through CasADi's conic interface (OSQP, qpOASES, DAQP; HPIPM for
    comparison), on the same arguments as `OcpQp`."""

    def __init__(self, qp: ca.Function, h: ca.Sparsity, a: ca.Sparsity) -> None:
        self.qp, self.h, self.a = qp, h, a

    def solve(self, hess: np.ndarray, jac: np.ndarray, grad: np.ndarray, lba: np.ndarray,
              uba: np.ndarray, lbx: np.ndarray, ubx: np.ndarray,
              out: np.ndarray) -> tuple[bool, int]:
        """The step into `out`, whether it solved and its iteration count."""
        sol = self.qp(h=ca.DM(self.h, hess[:-1]), g=grad, a=ca.DM(self.a, jac[:-1]), lba=lba,
                      uba=uba, lbx=lbx, ubx=ubx)
        stats = self.qp.stats()
        out[:] = np.asarray(sol["x"]).ravel()
        return bool(stats.get("success", False)), int(stats.get("iter_count", 0))


class _Interpreted:
    """The linearisation as a CasADi function (no C compiler): outputs as `CompiledFunction`
    gives them."""

    def __init__(self, fn: ca.Function) -> None:
        self.fn = fn

    def __call__(self, *args: np.ndarray) -> list[np.ndarray]:
        return [np.append(np.asarray(out.nonzeros(), dtype=float), 0.0)
                for out in self.fn(*args)]


class Rti:
    """The compiled linearisation and a QP solver for its sparsity: HPIPM through its own
    interface (`direct.py`), the other solvers through CasADi's."""

    def __init__(self, lin: ca.Function, spec: MpccController,
                 library: Path | None = None) -> None:
        self.lin = lin
        self.evaluate = CompiledFunction(lin, library) if library else _Interpreted(lin)
        h, a = lin.sparsity_out("hess_f"), lin.sparsity_out("jac_g")
        self.qp: OcpQp | ConicQp = (
            OcpQp(stages(spec.horizon_steps), h, a, spec.max_iterations, QP_TOL)
            if spec.qp_solver is QpSolver.HPIPM else
            ConicQp(ca.conic("mpcc_qp", spec.qp_solver.value, {"h": h, "a": a},
                             qp_options(spec)), h, a))

    def solve(self, w: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lbg: np.ndarray, ubg: np.ndarray, iterations: int) -> Iterate:
        """`iterations` full SQP steps from `w` (no line search: the RTI scheme), the last
        iterate's cost at its linearisation point. A QP that fails after others solved ends
        the iterations with the iterate so far, itself an RTI plan."""
        qp_iters, cost = 0, float("nan")
        step = np.empty(len(w))
        for done in range(iterations):
            g, jac, f, grad, hess = self.evaluate(w, p)
            cost = float(f[0])
            g = g[:-1]
            ok, iters = self.qp.solve(hess, jac, grad[:-1], lbg - g, ubg - g, lbw - w, ubw - w,
                                      step)
            qp_iters += iters
            if not ok or not np.isfinite(step).all():
                status = RtiStatus.QP_FAILED if done == 0 else RtiStatus.SOLVED_EARLY
                return Iterate(w, cost, status, qp_iters)
            w = w + step
        return Iterate(w, cost, RtiStatus.SOLVED, qp_iters)
