"""Fit the MPCC's own prediction model (`model`) to a kart's log: its single-track
parameters (read from the kart's own parameters, `SingleTrack.of`) checked against, and tuned
to, what the kart did.

The lateral part of the model is fitted: vy and yaw rate r, integrated (RK4, the log's step)
over windows of `window_s` from the recorded values, with the recorded forward speed and mean
front-wheel angle as inputs, against the recorded vy and r (both at the centre of gravity).
Method: scipy.optimize.least_squares, trust-region reflective, parameters scaled by their
start values and bounded to a third .. three times them."""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import casadi as ca
import numpy as np
from scipy.optimize import least_squares

from kartci.atomic import write_text_atomic
from kartci.errors import LogError, SpecError
from kartci.logs import SCENARIO_TOPIC, tables
from kartci.metrics import recorded_scenario
from kartci.robots.gokart.mpcc.model import DELTA, NU, NX, PSI, VX, VY, R, SingleTrack, continuous
from kartci.robots.gokart.mpcc.params import MpccVehicle
from kartci.robots.gokart.params import GokartModel, cog_x_m

STEER_JOINTS = ("front_left_wheel_steer_joint.position", "front_right_wheel_steer_joint.position")


@dataclass(frozen=True)
class Lateral:
    """Recorded lateral motion at the centre of gravity: t (s), vx, vy (m/s), r (rad/s), and
    the mean front-wheel angle delta (rad), on the odometry's samples."""

    t: np.ndarray
    vx: np.ndarray
    vy: np.ndarray
    r: np.ndarray
    delta: np.ndarray


def lateral_data(run_log: Path, agent: str, cog_x_m: float) -> Lateral:
    """The lateral motion of a kart run log (odometry and the steer joints' angles), moved
    from base_link to the centre of mass `cog_x_m` (m) ahead of it."""
    t = tables(run_log, [f"/{agent}/odom", f"/{agent}/joint_states"])
    odom, joints = t.get(f"/{agent}/odom"), t.get(f"/{agent}/joint_states")
    if odom is None or joints is None or not set(STEER_JOINTS) <= set(joints.columns):
        raise LogError(f"{run_log}: needs /{agent}/odom and the kart's steer joints on "
                       f"/{agent}/joint_states")
    ts = odom["t"].to_numpy(float)
    delta = np.interp(ts, joints["t"].to_numpy(float),
                      joints[list(STEER_JOINTS)].to_numpy(float).mean(axis=1))
    r = odom["wz"].to_numpy(float)
    return Lateral(ts - ts[0], odom["vx"].to_numpy(float),
                   odom["vy"].to_numpy(float) + r * cog_x_m, r, delta)


def fittable(track: SingleTrack) -> dict[str, float]:
    """The single-track model's parameters by name (`front.d_mps2` for a tyre's)."""
    out = {k: float(v) for k, v in vars(track).items() if isinstance(v, float | int)}
    for axle in ("front", "rear"):
        tyre = getattr(track, axle)
        out.update({f"{axle}.{k}": float(v) for k, v in tyre.model_dump().items()})
    return out


def _symbolic(track: SingleTrack, names: Sequence[str], p: Any) -> Any:
    """The track's parameters as a namespace, the named ones replaced by symbols of p."""
    tyres = {a: SimpleNamespace(**getattr(track, a).model_dump()) for a in ("front", "rear")}
    m = SimpleNamespace(**{**vars(track), **tyres})
    for i, name in enumerate(names):
        axle, _, field = name.rpartition(".")
        setattr(tyres[axle] if axle else m, field, p[i])
    return m


def _step_function(track: SingleTrack, vehicle: MpccVehicle, names: Sequence[str],
                   h: float) -> Any:
    """One RK4 step of (vy, r) with inputs vx, delta and the fitted parameters p (no
    longitudinal acceleration: the lateral dynamics alone)."""
    p = ca.SX.sym("p", len(names))
    m = _symbolic(track, names, p)
    vy, r, vx, delta = (ca.SX.sym(n) for n in ("vy", "r", "vx", "delta"))

    def f(vy_: Any, r_: Any) -> Any:
        x = ca.SX.zeros(NX)
        x[VX], x[VY], x[R], x[DELTA], x[PSI] = vx, vy_, r_, delta, 0
        dx = continuous(x, ca.SX.zeros(NU), m, vehicle)
        return dx[VY], dx[R]

    k1 = f(vy, r)
    k2 = f(vy + h / 2 * k1[0], r + h / 2 * k1[1])
    k3 = f(vy + h / 2 * k2[0], r + h / 2 * k2[1])
    k4 = f(vy + h * k3[0], r + h * k3[1])
    out = ca.vertcat(vy + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
                     r + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]))
    return ca.Function("step", [vy, r, vx, delta, p], [out])


def predict(data: Lateral, track: SingleTrack, vehicle: MpccVehicle, names: Sequence[str],
            values: Sequence[float], window_s: float) -> np.ndarray:
    """(vy, r) predicted at every sample, each window started from the recorded values."""
    h = float(np.median(np.diff(data.t)))
    step = _step_function(track, vehicle, names, h)
    per_window = max(1, round(window_s / h))
    out = np.empty((len(data.t), 2))
    p = np.asarray(values, float)
    for i in range(len(data.t)):
        if i % per_window == 0:
            state = np.array([data.vy[i], data.r[i]])
        else:
            state = np.asarray(step(state[0], state[1], data.vx[i - 1], data.delta[i - 1], p)
                               ).ravel()
        out[i] = state
    return out


@dataclass(frozen=True)
class MpccFit:
    """Fitted values and the yaw-rate / vy prediction RMS before and after."""

    names: tuple[str, ...]
    start: tuple[float, ...]
    values: tuple[float, ...]
    rms_before: tuple[float, float]  # vy m/s, r rad/s
    rms_after: tuple[float, float]


def fit_mpcc(data: Lateral, track: SingleTrack, vehicle: MpccVehicle, names: Sequence[str],
             window_s: float = 0.5) -> MpccFit:
    """Fit the named single-track parameters (see `fittable`) to the recorded lateral
    motion, starting from the kart's own."""
    fields = fittable(track)
    unknown = [n for n in names if n not in fields]
    if unknown:
        raise SpecError(f"--params {unknown[0]}: not a field of the MPCC's single-track model "
                        f"({', '.join(fields)})")
    start = np.array([fields[n] for n in names])
    measured = np.column_stack([data.vy, data.r])

    def residual(scaled: np.ndarray) -> np.ndarray:
        return np.asarray((predict(data, track, vehicle, names, scaled * start, window_s)
                           - measured).ravel())

    result = least_squares(residual, np.ones(len(names)), bounds=(1 / 3, 3.0), method="trf",
                           diff_step=1e-3, xtol=1e-6)

    def rms(scaled: np.ndarray) -> tuple[float, float]:
        err = residual(scaled).reshape(-1, 2)
        return float(np.sqrt(np.mean(err[:, 0] ** 2))), float(np.sqrt(np.mean(err[:, 1] ** 2)))

    return MpccFit(tuple(names), tuple(start.tolist()), tuple((result.x * start).tolist()),
                   rms(np.ones(len(names))), rms(result.x))


def fit_log(log: Path, names: list[str], out: Path) -> list[str]:
    """The MPCC's `Controller.fit` (`kartci calibrate --mpcc`): fit `names` to a simulated
    kart's run log, write OUT/mpcc_fit.json and say what changed, one line each."""
    scenario = recorded_scenario(tables(log, [SCENARIO_TOPIC]), log)
    agent, model = next(iter(scenario.agents.items()))
    if not isinstance(model.model, GokartModel):
        raise SpecError(f"{log}: --mpcc fits a go-kart's MPCC model; {agent} is a "
                        f"{model.model.kind}")
    fit = fit_mpcc(lateral_data(log, agent, cog_x_m(model.model)),
                   SingleTrack.of(model.model), MpccVehicle(), names)
    out.mkdir(parents=True, exist_ok=True)
    doc = {"log": str(log), "agent": agent, "params": dict(zip(fit.names, fit.values,
                                                                strict=True)),
           "start": dict(zip(fit.names, fit.start, strict=True)),
           "rms_before": {"vy_mps": fit.rms_before[0], "yaw_rate_radps": fit.rms_before[1]},
           "rms_after": {"vy_mps": fit.rms_after[0], "yaw_rate_radps": fit.rms_after[1]}}
    write_text_atomic(out / "mpcc_fit.json", json.dumps(doc, indent=2) + "\n")
    return [*(f"{name}: {start:g} -> {value:.6g}"
              for name, start, value in zip(fit.names, fit.start, fit.values, strict=True)),
            f"prediction RMS (vy m/s, yaw rate rad/s): {fit.rms_before[0]:.4g}, "
            f"{fit.rms_before[1]:.4g} -> {fit.rms_after[0]:.4g}, "
            f"{fit.rms_after[1]:.4g}; wrote {out / 'mpcc_fit.json'}"]
