"""`kartci calibrate`: fit named model parameters to a log by minimising the windowed sim-vs-log
divergence.

Method: scipy.optimize.least_squares, trust-region reflective ("trf") within the bounds, on
the parameters scaled by their starting values, with forward-difference Jacobians of 1 %
relative steps (PyBullet's contacts make the cost slightly rough below that). Residuals per
recorded sample of every window: x and y error (m), yaw error (rad, weighted 1 m/rad), speed
and yaw-rate residuals (weighted 0.2 s). Uncertainty: the Gauss-Newton covariance
s^2 (J^T J)^-1 at the optimum, s^2 = sum of squared residuals / (samples - parameters), given
as 95 % intervals (1.96 sigma); samples within a window are correlated, so these are optimistic.
"""

from __future__ import annotations

import json
import math
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from kartci.atomic import write_text_atomic
from kartci.errors import RunError, SpecError
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


@dataclass(frozen=True)
class Fit:
    """What a calibration found: values, 95 % intervals, divergence before and after."""

    params: tuple[Param, ...]
    values: tuple[float, ...]
    ci95: tuple[float, ...]
    before: dict[str, float]
    after: dict[str, float]
    evaluations: int
    method: str = "scipy.optimize.least_squares (trf, bounded, 1 % forward differences)"

    def overrides(self) -> list[str]:
        """The fitted values as `--set` overrides."""
        return [f"{p.path}={v!r}" for p, v in zip(self.params, self.values, strict=True)]

    def to_json(self) -> dict[str, Any]:
        """A plain JSON document of the fit."""
        return {"method": self.method, "evaluations": self.evaluations,
                "params": {p.path: {"start": p.start, "bounds": [p.lo, p.hi], "value": v,
                                    "ci95": c}
                           for p, v, c in zip(self.params, self.values, self.ci95, strict=True)},
                "before": self.before, "after": self.after}


def _lookup(data: Any, path: str) -> Any:
    for part in path.split("."):
        if not isinstance(data, dict) or part not in data:
            raise SpecError(f"--params {path}: no such key in the resolved scenario (at "
                            f"'{part}')")
        data = data[part]
    return data


def parse_params(setup: SimSetup, given: Sequence[str]) -> tuple[Param, ...]:
    """`model.NAME` (the agent's model) or a full dotted path, optionally `=LO:HI`; default
    bounds: half to twice the starting value."""
    agent = next(iter(setup.scenario.agents))
    data = setup.scenario.model_dump(mode="json")
    out = []
    for item in given:
        key, _, bounds = item.partition("=")
        key = key.strip()
        path = key if key.startswith("agents.") else f"agents.{agent}.{key}"
        value = _lookup(data, path)
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
                 params: tuple[Param, ...], drive: Drive, window_s: float) -> None:
        self.profile, self.scenario, self.base = profile, scenario, list(base)
        self.params, self.drive, self.window_s = params, drive, window_s
        self.calls = 0

    def setup(self, values: Sequence[float]) -> SimSetup:
        """The scenario with these parameter values."""
        sets = [f"{p.path}={float(v)!r}" for p, v in zip(self.params, values, strict=True)]
        return sim_setup(self.profile, self.scenario, [*self.base, *sets])

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


def calibrate(objective: Objective) -> Fit:
    """Fit the objective's parameters; divergence before (start values) and after."""
    params = objective.params
    lo = np.array([p.lo / p.start for p in params])
    hi = np.array([p.hi / p.start for p in params])
    result = least_squares(objective, np.ones(len(params)), bounds=(lo, hi), method="trf",
                           diff_step=0.01, x_scale=1.0, xtol=1e-4, ftol=1e-6, max_nfev=60)
    values = [float(s * p.start) for s, p in zip(result.x, params, strict=True)]
    ci = _ci95(result.jac, result.fun, params)
    before = objective.metrics([p.start for p in params])
    after = objective.metrics(values)
    return Fit(params, tuple(values), ci, before, after, objective.calls)


def _ci95(jac: np.ndarray, fun: np.ndarray, params: tuple[Param, ...]) -> tuple[float, ...]:
    m, n = jac.shape
    s2 = float(fun @ fun) / max(m - n, 1)
    try:
        cov = np.linalg.inv(jac.T @ jac) * s2
    except np.linalg.LinAlgError:
        return tuple(math.inf for _ in params)
    return tuple(float(1.96 * math.sqrt(max(cov[i, i], 0.0)) * p.start)
                 for i, p in enumerate(params))


def overlay_yaml(fit: Fit, log: str) -> str:
    """The fitted values as a YAML overlay: dotted keys a scenario's `--set` takes."""
    lines = [f"# kartci calibrate of {log}: {fit.method}",
             f"# windowed APE {fit.before['simreal_ape_window_rmse_m']:.4g} m -> "
             f"{fit.after['simreal_ape_window_rmse_m']:.4g} m"]
    for p, v, c in zip(fit.params, fit.values, fit.ci95, strict=True):
        lines.append(f"{p.path}: {json.dumps(v)}  # start {p.start:g}, 95 % +- {c:.3g}")
    return "\n".join(lines) + "\n"


def calibrate_log(log: Path, profile_path: Path | None, scenario: str | None,
                  overrides: Sequence[str], names: Sequence[str], window_s: float,
                  out: Path, allow_outside_paths: bool = False) -> Fit:
    """Fit `names` to `log`; writes OUT/calibration.json and OUT/overlay.yaml. The profile's
    files stay inside the project unless `allow_outside_paths` (`--allow-outside-paths`)."""
    profile, info = resolve_profile(log, profile_path, allow_outside_paths)
    types = {role: i.msgtype for role, i in info.items()}
    setup = sim_setup(profile, scenario, overrides)
    check_commands(setup, profile, types)
    params = parse_params(setup, names)
    with tempfile.TemporaryDirectory() as tmp:
        imported = Path(tmp) / "imported.mcap"
        import_log(log, profile, types, imported)
        drive = read_drive(imported, profile.agent)
    fit = calibrate(Objective(profile, scenario, overrides, params, drive, window_s))
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "calibration.json", json.dumps(fit.to_json(), indent=2) + "\n")
    write_text_atomic(out / "overlay.yaml", overlay_yaml(fit, str(log)))
    return fit
