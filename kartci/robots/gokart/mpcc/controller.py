"""One MPCC solve per control period: measured state in, a command and the predicted horizon
out. Warm-started from the previous solution shifted by one step, solved to convergence with
Ipopt or by real-time iterations (`rti.py`); a failed solve brakes."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from kartci.robots.gokart import STEERING_RATIO, wheel_angles
from kartci.robots.gokart.mpcc.cache import Built, get_solver
from kartci.robots.gokart.mpcc.model import (
    ACC,
    DELTA,
    NX,
    PSI,
    SLACK,
    VS,
    VX,
    S,
    SingleTrack,
    X,
    Y,
)
from kartci.robots.gokart.mpcc.ocp import (
    STAGE_PARAMS,
    constraint_bounds,
    variable_bounds,
    weights_vector,
)
from kartci.robots.gokart.mpcc.params import MpccController
from kartci.robots.gokart.mpcc.reference import (
    DEFAULT_FLOOR_FRICTION,
    FrictionMap,
    Obstacle,
    TrackWidths,
    progress_guess,
    stage_params,
)
from kartci.robots.gokart.mpcc.rti import Rti
from kartci.robots.gokart.outline import footprint_m, half_width_m
from kartci.robots.gokart.params import GokartModel
from kartci.worlds.track import Track

SUCCESS = {"Solve_Succeeded", "Solved_To_Acceptable_Level", "Success"}
FEASIBLE = 1e-4  # largest constraint violation of a usable iterate (m, m/s, ...)


@dataclass(frozen=True)
class Plan:
    """The outcome of one solve: the command, the predicted horizon and solver statistics."""

    success: bool
    status: str
    iterations: int  # Ipopt iterations; in RTI the QP solver iterations of all its QPs
    solve_ms: float
    cost: float
    slack_m: float  # stage 1's: how far past its bounds the state the command leads to lies
    states: np.ndarray  # (N + 1, NX) predicted states; on failure the braking fallback
    accel_mps2: float  # the command: longitudinal acceleration (negative: brake)
    wheel_angle_rad: float  # mean front-wheel angle to steer to


class Mpcc:
    """The MPCC on one track, each solve warm-started from the last successful one."""

    def __init__(self, spec: MpccController, model: GokartModel, track: Track,
                 friction: FrictionMap | None = None) -> None:
        self.spec, self.model, self.track = spec, model, track
        # the floor the map knows; none: everywhere concrete
        self.friction = friction or FrictionMap(DEFAULT_FLOOR_FRICTION, (), model.tire_friction)
        self.single_track = SingleTrack.of(model)
        self.built: Built = get_solver(spec, self.single_track)
        self.lay = self.built.layout
        self.lbg, self.ubg = constraint_bounds(spec.horizon_steps)
        # the outline's half width plus the margin keeps the whole kart off the edges
        self.padding_m = half_width_m(model) + spec.track_margin_m
        self.kart_length_m = footprint_m(model)[1]
        lo, hi = model.steering_limit_rad
        col = spec.max_column_rad
        self.max_delta = min(abs(sum(wheel_angles(model, max(lo, -col))) / 2),
                             abs(sum(wheel_angles(model, min(hi, col))) / 2),
                             STEERING_RATIO * 1.7)
        self.widths = TrackWidths.of(track)
        # what does not change between solves, worked out once: the parameters before the
        # stages' (weights and limits), and the box bounds but for x_0's (the measurement)
        self._p_head = np.array([*weights_vector(spec.weights), spec.max_lateral_accel_mps2,
                                 spec.max_brake_mps2, spec.front_check_m, spec.max_speed_mps])
        self._bounds = variable_bounds(spec, self.lay, np.zeros(NX), self.max_delta)
        self._w: np.ndarray | None = None
        self._lam_g: np.ndarray | None = None
        self._lam_x: np.ndarray | None = None
        self.failures = 0

    def solve(self, x0: np.ndarray, obstacles: list[Obstacle]) -> Plan:
        """One solve from `x0` = [X, Y, psi, vx, vy, r, s, delta, acc]; retried cold once when a
        warm start fails, else the braking fallback."""
        sp, lay = self.spec, self.lay
        x0 = x0.copy()
        x0[DELTA] = float(np.clip(x0[DELTA], -self.max_delta, self.max_delta))
        x0[ACC] = float(np.clip(x0[ACC], -sp.max_brake_mps2, sp.max_accel_mps2))
        t0 = time.perf_counter()
        warm = self._w is not None
        sol, status, ok, iters = self._attempt(x0, obstacles, self.built.rti or self.built.solver)
        if not ok and warm:  # a warm start can trap the solver: retry once, fresh
            self._w = self._lam_g = self._lam_x = None
            sol, status, ok, more = self._attempt(x0, obstacles,
                                                  self.built.rti or self.built.cold)
            iters += more
        # wall clock: recorded as SolverStats.solve_ms, declared in ..messages.WALL_CLOCK
        solve_ms = (time.perf_counter() - t0) * 1e3
        w = np.asarray(sol["x"]).ravel()
        if not ok:
            self.failures += 1
            self._w = self._lam_g = self._lam_x = None
            return self._brake(x0, status, iters, solve_ms)
        self._w = w
        if "lam_g" in sol:  # Ipopt's multipliers warm-start its next solve
            self._lam_g = np.asarray(sol["lam_g"]).ravel()
            self._lam_x = np.asarray(sol["lam_x"]).ravel()
        states = lay.states(w)
        # the applied stage's slack, not the horizon's maximum: a later stage's is a plan the
        # next solves revise, and its peaks moved with a 1 nm change of the start
        slack = float(lay.inputs(w)[1, SLACK])
        return Plan(True, status, iters, solve_ms, float(sol["f"]), slack, states,
                    float(states[0, ACC] + states[1, ACC]) / 2, float(states[1, DELTA]))

    def _attempt(self, x0: np.ndarray, obstacles: list[Obstacle],
                 solver: Any) -> tuple[dict[str, Any], str, bool, int]:
        """One solve from the current guess (the last solution shifted, else fresh): Ipopt's,
        or the real-time iterations."""
        sp, lay = self.spec, self.lay
        cold = self._w is None
        w0 = self._initial_guess(x0)
        guess = lay.states(w0)[1:]
        p = np.empty(len(self._p_head) + STAGE_PARAMS * sp.horizon_steps)
        p[:len(self._p_head)] = self._p_head
        stage = p[len(self._p_head):].reshape(sp.horizon_steps, STAGE_PARAMS)
        stage[:, :-1] = stage_params(self.widths, guess[:, S], sp.step_s, self.padding_m,
                                     obstacles, sp.obstacle_margin_m, self.kart_length_m,
                                     sp.track_margin_m - sp.passing_margin_m)
        stage[:, -1] = self._grip(guess)
        lbw, ubw = (b.copy() for b in self._bounds)
        lbw[lay.x(0)] = ubw[lay.x(0)] = x0
        if isinstance(solver, Rti):
            it = solver.solve(w0, p, lbw, ubw, self.lbg, self.ubg,
                              sp.sqp_cold_iterations if cold else sp.sqp_iterations)
            return {"x": it.w, "f": it.cost}, it.status, it.ok, it.qp_iterations
        args = {"x0": w0, "p": p, "lbx": lbw, "ubx": ubw, "lbg": self.lbg, "ubg": self.ubg}
        if self._lam_g is not None and self._lam_x is not None:
            args["lam_g0"], args["lam_x0"] = self._lam_g, self._lam_x
        sol = solver(**args)
        stats = solver.stats()
        status = str(stats.get("return_status", "unknown"))
        w = np.asarray(sol["x"]).ravel()
        g = np.asarray(sol["g"]).ravel()
        violation = float(np.max(np.maximum(self.lbg - g, g - self.ubg), initial=0.0))
        ok = bool(np.isfinite(w).all()) and (
            status in SUCCESS
            # the iteration cap with a feasible iterate: a usable, suboptimal plan, as in
            # real-time MPC; an infeasible iterate is a failure
            or (status == "Maximum_Iterations_Exceeded" and violation < FEASIBLE))
        return sol, status, ok, int(stats.get("iter_count", -1))

    def _grip(self, states: np.ndarray) -> np.ndarray:
        """The tyres' grip at each predicted stage (the last plan's poses): the least under
        either axle, so that the plan slows before the first wheel reaches a slippery zone."""
        heading = np.column_stack([np.cos(states[:, PSI]), np.sin(states[:, PSI])])
        xy = states[:, [X, Y]]
        m = self.single_track
        out: np.ndarray = np.minimum(self.friction.grip(xy + m.lf_m * heading),
                                     self.friction.grip(xy - m.lr_m * heading))
        return out

    def _initial_guess(self, x0: np.ndarray) -> np.ndarray:
        lay, sp = self.lay, self.spec
        if self._w is not None:  # shift the last solution by one step
            xs, us = lay.states(self._w), lay.inputs(self._w)
            xs = np.vstack([xs[1:], xs[-1:]])
            xs[-1, S] += xs[-1, VX] * sp.step_s
            us = np.vstack([us[1:], us[-1:]])
            offset = x0[S] - xs[0, S]
            xs[:, S] += offset
            if self.built.rti is not None:  # a measured heading that wrapped by 2 pi would
                # linearise cos/sin far off; Ipopt iterates it away, its results stay as they were
                xs[:, PSI] += 2 * math.pi * round((x0[PSI] - xs[0, PSI]) / (2 * math.pi))
        else:
            s = progress_guess(float(x0[S]), float(x0[VX]), sp.step_s,
                               sp.horizon_steps, sp.max_speed_mps)
            xs = np.tile(x0, (sp.horizon_steps + 1, 1))
            xs[1:, S] = s
            xs[1:, VX] = np.diff(np.r_[x0[S], s]) / sp.step_s
            self._along_track(xs, x0)
            us = np.zeros((sp.horizon_steps, 4))
            us[:, VS] = xs[1:, VX]
            self._lam_g = self._lam_x = None
        xs[0] = x0
        return lay.pack(xs, us)

    def _along_track(self, xs: np.ndarray, x0: np.ndarray) -> None:
        """A fresh guess's poses: on the track at the guessed progress, at the kart's lateral
        offset, so that the guess moves as its speeds say (the dynamic model's solver needs
        that from a standstill)."""
        lateral = float(self.track.project(x0[None, :2])[1][0])
        poses = np.array([self.track.pose_at(float(s), lateral) for s in xs[1:, S]])
        xs[1:, X], xs[1:, Y] = poses[:, 0], poses[:, 1]
        xs[1:, PSI] = np.unwrap(np.r_[x0[PSI], poses[:, 2]])[1:]

    def reset(self) -> None:
        """Forget the last plan: the next solve starts from a fresh guess."""
        self._w = self._lam_g = self._lam_x = None

    def brake_straight(self, x0: np.ndarray, status: str) -> Plan:
        """Full brake with the wheels straight, no solve: the recovery from a loss of control
        (a sliding kart steered into the slide by a model that does not slide spins on)."""
        self.reset()
        plan = self._brake(x0, status, 0, 0.0)
        return Plan(False, status, 0, 0.0, math.nan, math.nan, plan.states, plan.accel_mps2,
                    0.0)

    def _brake(self, x0: np.ndarray, status: str, iters: int, solve_ms: float) -> Plan:
        """Full brake, steering held: the safe reaction to a failed solve."""
        states = np.tile(x0, (self.spec.horizon_steps + 1, 1))
        v, t = float(x0[VX]), self.spec.step_s * np.arange(self.spec.horizon_steps + 1)
        speed = np.maximum(v - self.spec.max_brake_mps2 * t, 0.0)
        states[:, VX] = speed
        heading = x0[2]
        dist = np.concatenate([[0.0], np.cumsum(speed[:-1] * self.spec.step_s)])
        states[:, 0] = x0[0] + dist * math.cos(heading)
        states[:, 1] = x0[1] + dist * math.sin(heading)
        return Plan(False, status, iters, solve_ms, math.nan, math.nan, states,
                    -self.spec.max_brake_mps2, float(x0[DELTA]))


