"""`kartci calibrate`: fit named model parameters to a log by minimising the windowed sim-vs-log
divergence.

Method: scipy.optimize.least_squares, trust-region reflective ("trf") within the bounds, on
the parameters scaled by their starting values, with forward-difference Jacobians of 1 %
relative steps (PyBullet's contacts make the cost slightly rough below that). Residuals per
recorded sample of every window: x and y error (m), yaw error (rad, weighted 1 m/rad), speed
and yaw-rate residuals (weighted 0.2 s). Uncertainty: the Gauss-Newton covariance
s^2 (J^T J)^-1 at the optimum, s^2 = sum of squared residuals / (samples - parameters), given
as 95 % intervals (1.96 sigma); samples within a window are correlated, so these are optimistic.
A parameter the divergence does not change with, or whose effect another parameter's mimics
(J^T J singular), has no interval: it is "not identifiable from this log", with the reason. A
value at (within 0.1 % of the range from) one of its bounds is flagged with that bound: the
optimum may lie beyond it, and the model may be missing something (a speed limit) that the
parameter absorbs. Parameters `profile.commands.NAME` are the profile's base-controller
kinematics and limits (a differential drive's wheel radius, separation, speed and acceleration
limits), fitted the same way.
"""

from __future__ import annotations

import json
import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from kartci.atomic import write_text_atomic
from kartci.errors import RunError, SpecError
from kartci.project import Project
from kartci.realdata.divergence import divergence, residuals, run_whole, run_windows
from kartci.realdata.drive import Drive, read_drive
from kartci.realdata.importer import import_log
from kartci.realdata.plant import Plant
from kartci.realdata.profile import Profile, resolve_profile
from kartci.realdata.simreal import SimSetup, check_commands, sim_setup

WEIGHTS = np.array([1.0, 1.0, 1.0, 0.2, 0.2])  # x m, y m, yaw m/rad, speed s, yaw rate m s/rad


@dataclass(frozen=True)
class Param:
    """One parameter to fit: its dotted path in the scenario, start value and bounds."""

    path: str  # full dotted path, e.g. agents.kart0.model.speed_gain_per_s
    start: float
    lo: float
    hi: float


class Bound(Enum):
    """Which bound a fitted value sits at."""

    LOWER = "lower"
    UPPER = "upper"


@dataclass(frozen=True)
class Estimate:
    """One fitted value: its 95 % interval half-width (None: not identifiable, `why`) and the
    bound it sits at, if any."""

    value: float
    ci95: float | None
    why: str = ""
    bound: Bound | None = None

    def interval(self) -> str:
        """The interval as printed: a number, or why there is none."""
        return f"+- {self.ci95:.3g}" if self.ci95 is not None else (
            f"not identifiable from this log: {self.why}")

    def note(self, p: Param) -> str:
        """The bound flag, as printed."""
        if self.bound is None:
            return ""
        at = p.lo if self.bound is Bound.LOWER else p.hi
        return f"at its {self.bound.value} bound {at:g}: widen it, or the model lacks something"


@dataclass(frozen=True)
class Fit:
    """What a calibration found: values with intervals and bound flags, divergence before and
    after."""

    params: tuple[Param, ...]
    estimates: tuple[Estimate, ...]
    before: dict[str, float]
    after: dict[str, float]
    evaluations: int
    method: str = "scipy.optimize.least_squares (trf, bounded, 1 % forward differences)"

    @property
    def values(self) -> tuple[float, ...]:
        """The fitted values, in the order of `params`."""
        return tuple(e.value for e in self.estimates)

    def overrides(self) -> list[str]:
        """The fitted values as `--set` overrides."""
        return [f"{p.path}={v!r}" for p, v in zip(self.params, self.values, strict=True)]

    def to_json(self) -> dict[str, Any]:
        """A plain JSON document of the fit."""
        return {"method": self.method, "evaluations": self.evaluations,
                "params": {p.path: {"start": p.start, "bounds": [p.lo, p.hi], "value": e.value,
                                    "ci95": e.ci95, "not_identifiable": e.why or None,
                                    "at_bound": e.bound.value if e.bound else None}
                           for p, e in zip(self.params, self.estimates, strict=True)},
                "before": self.before, "after": self.after}


def _lookup(data: Any, path: str) -> Any:
    for part in path.split("."):
        if not isinstance(data, dict) or part not in data:
            raise SpecError(f"--params {path}: no such key in the resolved scenario (at "
                            f"'{part}')")
        data = data[part]
    return data


PROFILE = "profile."  # parameters of the import profile rather than the scenario


def parse_params(setup: SimSetup, given: Sequence[str],
                 profile: Profile | None = None) -> tuple[Param, ...]:
    """`model.NAME` (the agent's model), a full dotted path or `profile.commands.NAME` (the
    profile's), optionally `=LO:HI`; default bounds: half to twice the starting value."""
    agent = next(iter(setup.scenario.agents))
    data = setup.scenario.model_dump(mode="json")
    data["profile"] = profile.model_dump(mode="json") if profile is not None else {}
    out = []
    for item in given:
        key, _, bounds = item.partition("=")
        key = key.strip()
        path = key if key.startswith(("agents.", PROFILE)) else f"agents.{agent}.{key}"
        value = _lookup(data, path)
        if value is None and path.startswith(PROFILE):
            raise SpecError(f"--params {key}: the profile sets no value to start from; set "
                            "one in the profile")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise SpecError(f"--params {key}: {value!r} is not a number")
        lo, hi = (0.5 * value, 2.0 * value) if not bounds else _bounds(key, bounds)
        lo, hi = min(lo, hi), max(lo, hi)
        if not lo < hi or not lo <= value <= hi:
            raise SpecError(f"--params {key}: bounds [{lo:g}, {hi:g}] must hold the start "
                            f"value {value:g} and have a width")
        out.append(Param(path, float(value), float(lo), float(hi)))
    if not out:
        raise SpecError("--params: name at least one parameter to fit")
    return tuple(out)


def _bounds(key: str, text: str) -> tuple[float, float]:
    lo, sep, hi = text.partition(":")
    try:
        if not sep:
            raise ValueError(text)
        return float(lo), float(hi)
    except ValueError as err:
        raise SpecError(f"--params {key}={text}: bounds are LO:HI, two numbers") from err


class Objective:
    """The windowed divergence as a residual vector of the parameter values."""

    def __init__(self, profile: Profile, scenario: str | None, base: Sequence[str],
                 params: tuple[Param, ...], drive: Drive, window_s: float,
                 proj: Project) -> None:
        self.profile, self.scenario, self.base, self.proj = profile, scenario, list(base), proj
        self.params, self.drive, self.window_s = params, drive, window_s
        self.calls = 0

    def setup(self, values: Sequence[float]) -> SimSetup:
        """The scenario (and profile) with these parameter values."""
        pairs = list(zip(self.params, values, strict=True))
        sets = [f"{p.path}={float(v)!r}" for p, v in pairs if not p.path.startswith(PROFILE)]
        profile = with_values(self.profile, {p.path.removeprefix(PROFILE): float(v)
                                             for p, v in pairs if p.path.startswith(PROFILE)})
        return sim_setup(profile, self.scenario, [*self.base, *sets], self.proj)

    def runs(self, values: Sequence[float]) -> dict[str, Any]:
        """Windowed and whole-log runs with these values."""
        setup = self.setup(values)
        plant = Plant(setup.scenario, self.drive, setup.convert)
        try:
            return {"windows": run_windows(plant, self.drive, self.window_s),
                    "whole": run_whole(plant, self.drive)}
        finally:
            plant.close()

    def __call__(self, scaled: np.ndarray) -> np.ndarray:
        """Weighted residuals of the windowed run (parameters scaled by their start values)."""
        self.calls += 1
        values = [s * p.start for s, p in zip(scaled, self.params, strict=True)]
        setup = self.setup(values)
        plant = Plant(setup.scenario, self.drive, setup.convert)
        try:
            t, sim = run_windows(plant, self.drive, self.window_s)
        finally:
            plant.close()
        res = residuals(self.drive_at(t), sim) * WEIGHTS
        if not np.all(np.isfinite(res)):
            raise RunError(f"calibration: the sim diverged (non-finite state) at {values}")
        return np.asarray(res.ravel())

    def drive_at(self, t: np.ndarray) -> np.ndarray:
        """The log's state at these times."""
        return np.column_stack([np.interp(t, self.drive.t_s, self.drive.state[:, i])
                                for i in range(6)])

    def metrics(self, values: Sequence[float]) -> dict[str, float]:
        """The divergence metrics of these values."""
        runs = self.runs(values)
        (t, sim_w), (ta, sim_a) = runs["windows"], runs["whole"]
        return divergence(t, self.drive_at(t), sim_w, ta, self.drive_at(ta), sim_a)


def with_values(profile: Profile, values: dict[str, float]) -> Profile:
    """The profile with these dotted fields (`commands.max_speed_mps`) set."""
    if not values:
        return profile
    data = profile.model_dump()
    for path, value in values.items():
        *parents, last = path.split(".")
        node = data
        for part in parents:
            node = node[part]
        node[last] = value
    return Profile.model_validate(data)


def calibrate(objective: Objective) -> Fit:
    """Fit the objective's parameters; divergence before (start values) and after."""
    params = objective.params
    lo = np.array([p.lo / p.start for p in params])
    hi = np.array([p.hi / p.start for p in params])
    result = least_squares(objective, np.ones(len(params)), bounds=(lo, hi), method="trf",
                           diff_step=0.01, x_scale=1.0, xtol=1e-4, ftol=1e-6, max_nfev=60)
    values = [float(s * p.start) for s, p in zip(result.x, params, strict=True)]
    estimates = estimate(result.jac, result.fun, params, values)
    before = objective.metrics([p.start for p in params])
    after = objective.metrics(values)
    return Fit(params, estimates, before, after, objective.calls)


def _at_bound(p: Param, value: float) -> Bound | None:
    tol = 1e-3 * (p.hi - p.lo)
    return (Bound.LOWER if value <= p.lo + tol else Bound.UPPER if value >= p.hi - tol
            else None)


def _unidentifiable(jac: np.ndarray, params: tuple[Param, ...]) -> dict[int, str]:
    """Why some parameters have no interval: the divergence does not change with one (a zero
    Jacobian column), or another's effect mimics it (columns nearly parallel)."""
    norms = np.linalg.norm(jac, axis=0)
    why = {i: "the divergence does not change with it (the log does not excite it)"
           for i in range(len(params)) if norms[i] <= 1e-12 * max(float(norms.max()), 1e-300)}
    unit = jac / np.where(norms > 0, norms, 1.0)
    moving = [i for i in range(len(params)) if i not in why]
    parallel = {i: next((j for j in moving if j != i
                         and abs(float(unit[:, i] @ unit[:, j])) > 1 - 1e-9), None)
                for i in moving}
    why.update({i: f"its effect cannot be told apart from {params[j].path}'s (fix one of them)"
                for i, j in parallel.items() if j is not None})
    return why


def estimate(jac: np.ndarray, fun: np.ndarray, params: tuple[Param, ...],
             values: Sequence[float]) -> tuple[Estimate, ...]:
    """Each value with its Gauss-Newton 95 % interval, or why it has none, and its bound."""
    m, n = jac.shape
    s2 = float(fun @ fun) / max(m - n, 1)
    why = _unidentifiable(jac, params)
    free = [i for i in range(n) if i not in why]
    sigma = np.full(n, math.nan)
    if free:
        sub = jac[:, free]
        try:
            cov = np.linalg.inv(sub.T @ sub) * s2
            sigma[free] = np.sqrt(np.maximum(np.diag(cov), 0.0))
        except np.linalg.LinAlgError:
            why.update({i: "the fit's curvature is singular in it" for i in free})
    return tuple(Estimate(float(v), None if i in why or not math.isfinite(sigma[i])
                          else float(1.96 * sigma[i] * p.start), why.get(i, ""),
                          _at_bound(p, float(v)))
                 for i, (p, v) in enumerate(zip(params, values, strict=True)))


def overlay_yaml(fit: Fit, log: str) -> str:
    """The fitted values as a YAML overlay: dotted keys a scenario's `--set` takes."""
    lines = [f"# kartci calibrate of {log}: {fit.method}",
             f"# windowed APE {fit.before['simreal_ape_window_rmse_m']:.4g} m -> "
             f"{fit.after['simreal_ape_window_rmse_m']:.4g} m"]
    for p, e in zip(fit.params, fit.estimates, strict=True):
        note = "; ".join(x for x in (e.interval(), e.note(p)) if x)
        lines.append(f"{p.path}: {json.dumps(e.value)}  # start {p.start:g}, 95 % {note}")
    return "\n".join(lines) + "\n"


def calibrate_log(log: Path, profile_path: Path | None, scenario: str | None,
                  overrides: Sequence[str], names: Sequence[str], window_s: float,
                  out: Path, proj: Project, allow_outside_paths: bool = False) -> Fit:
    """Fit `names` to `log`; writes OUT/calibration.json and OUT/overlay.yaml. The profile's
    files stay inside the project unless `allow_outside_paths` (`--allow-outside-paths`)."""
    profile, info = resolve_profile(log, profile_path, proj, allow_outside_paths)
    types = {role: i.msgtype for role, i in info.items()}
    setup = sim_setup(profile, scenario, overrides, proj)
    check_commands(setup, profile, types)
    params = parse_params(setup, names, profile)
    with tempfile.TemporaryDirectory() as tmp:
        imported = Path(tmp) / "imported.mcap"
        import_log(log, profile, types, imported)
        drive = read_drive(imported, profile.agent)
    fit = calibrate(Objective(profile, scenario, overrides, params, drive, window_s, proj))
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "calibration.json", json.dumps(fit.to_json(), indent=2) + "\n")
    write_text_atomic(out / "overlay.yaml", overlay_yaml(fit, str(log)))
    return fit
