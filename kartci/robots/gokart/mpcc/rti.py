"""Real-time iterations (RTI) of SQP for the MPCC (Diehl's RTI scheme, as in acados and
Liniger's kart MPCC): per control step a fixed number of QPs, each the NLP linearised around the
current iterate (the last solution shifted by one step), with the cost's own Hessian (the
contouring and lag errors are linear in the state, so the Gauss-Newton Hessian is exact for the
cost; constraint curvature is dropped) plus a small Levenberg-Marquardt term. The QP keeps the
multiple-shooting structure that HPIPM's Riccati recursion exploits."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import Any

import casadi as ca
import numpy as np

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


def _qp_options(spec: MpccController) -> dict[str, Any]:
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


class Rti:
    """The compiled linearisation and a QP solver for its sparsity."""

    def __init__(self, lin: ca.Function, spec: MpccController) -> None:
        self.lin = lin
        sparsity = {"h": lin.sparsity_out("hess_f"), "a": lin.sparsity_out("jac_g")}
        self.qp = ca.conic("mpcc_qp", spec.qp_solver.value, sparsity, _qp_options(spec))

    def solve(self, w: np.ndarray, p: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              lbg: np.ndarray, ubg: np.ndarray, iterations: int) -> Iterate:
        """`iterations` full SQP steps from `w` (no line search: the RTI scheme), the last
        iterate's cost at its linearisation point. A QP that fails after others solved ends
        the iterations with the iterate so far, itself an RTI plan."""
        qp_iters, cost = 0, float("nan")
        for done in range(iterations):
            g, jac, f, grad, hess = self.lin(w, p)
            cost = float(f)
            g = np.asarray(g).ravel()
            sol = self.qp(h=hess, g=grad, a=jac, lba=lbg - g, uba=ubg - g, lbx=lbw - w,
                          ubx=ubw - w)
            stats = self.qp.stats()
            qp_iters += int(stats.get("iter_count", 0))
            step = np.asarray(sol["x"]).ravel()
            if not stats.get("success", False) or not np.isfinite(step).all():
                status = RtiStatus.QP_FAILED if done == 0 else RtiStatus.SOLVED_EARLY
                return Iterate(w, cost, status, qp_iters)
            w = w + step
        return Iterate(w, cost, RtiStatus.SOLVED, qp_iters)
