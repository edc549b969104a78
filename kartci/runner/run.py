"""Run scenarios into an output folder, score their logs and judge them against baselines.

Layout of OUT: `<scenario>/run.mcap` (the log), `<scenario>/metrics.json` (deterministic),
`<scenario>/run.json` (wall-clock facts), and the suite reports at the top.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from kartci import geometry, metrics
from kartci.errors import KartciError, LogError
from kartci.logs import tables
from kartci.results import Plots, ScenarioResult
from kartci.sim import simulate
from kartci.spec import Scenario, load_scenario, project_root
from kartci.verdict import check_criteria, compare, load, write_json_atomic

LOG_NAME = "run.mcap"


def default_baselines() -> Path:
    return project_root() / "baselines"


def run_one(scenario: Scenario, out: Path,
            on_progress: Callable[[float], None] | None = None) -> dict[str, Any]:
    """Simulate one scenario and score its log; returns the run facts (raises KartciError)."""
    folder = out / scenario.name
    t0 = time.perf_counter()
    info = simulate(scenario, folder / LOG_NAME, on_progress)
    wall = time.perf_counter() - t0
    score(folder)
    run = {"sim_time_s": round(info.sim_time_s, 6), "wall_s": round(wall, 3),
           "real_time_factor": round(info.sim_time_s / wall, 2) if wall > 0 else None,
           "messages": info.messages, "finished_course": info.finished_course,
           "log": str(folder / LOG_NAME)}
    write_json_atomic(folder / "run.json", run)
    return run


def score(folder: Path) -> dict[str, Any]:
    """Compute metrics.json from the log in `folder` (byte-identical for identical logs)."""
    scenario, values = metrics.compute(folder / LOG_NAME)
    doc = {"scenario": scenario.name, "seed": scenario.seed,
           "metrics": {name: m.to_json() for name, m in values.items()}}
    write_json_atomic(folder / "metrics.json", doc)
    return doc


def plots(folder: Path, scenario: Scenario) -> Plots:
    t = tables(folder / LOG_NAME)
    tracks: dict[str, pd.DataFrame] = {}
    wheels: dict[str, pd.DataFrame] = {}
    commands: dict[str, pd.DataFrame] = {}
    for agent in scenario.agents:
        odom = t.get(f"/{agent}/odom")
        if odom is not None:
            tracks[agent] = metrics.sensor_track(scenario, agent, odom)
        for topic, target in ((f"/{agent}/joint_states", wheels), (f"/{agent}/wheel_cmd",
                                                                    commands)):
            df = t.get(topic)
            if df is not None:
                target[agent] = pd.DataFrame({"t": df["t"],
                                              "left": df["left_wheel_hinge.velocity"],
                                              "right": df["right_wheel_hinge.velocity"]})
    course = geometry.polyline(scenario.world.course, 400)
    return Plots(np.asarray(course), scenario.world.line_width_m, tracks, wheels, commands,
                 scenario.metrics.transient_s)


def evaluate(folder: Path, baselines: Path, with_plots: bool = True) -> ScenarioResult:
    """Judge one scenario folder (metrics.json + log) against its baseline and criteria."""
    name = folder.name
    try:
        doc = json.loads((folder / "metrics.json").read_text(encoding="utf-8"))
        scenario, _ = _recorded(folder)
        values = doc["metrics"]
        verdicts = compare(values, load(baselines / f"{name}.json"))
        crit = check_criteria(values, scenario.criteria)
        run_path = folder / "run.json"
        run = json.loads(run_path.read_text(encoding="utf-8")) if run_path.exists() else {}
        return ScenarioResult(name, scenario.description, verdicts, crit, None, run,
                              plots(folder, scenario) if with_plots else None)
    except (KartciError, OSError, ValueError, KeyError) as err:
        return ScenarioResult(name, "", error=str(err))


def _recorded(folder: Path) -> tuple[Scenario, dict[str, pd.DataFrame]]:
    t = tables(folder / LOG_NAME, ["/kartci/scenario"])
    return metrics.recorded_scenario(t, folder / LOG_NAME), t


def run_suite(names: list[str], overrides: list[str], out: Path, baselines: Path,
              on_done: Callable[[str, ScenarioResult], None] | None = None,
              on_progress: Callable[[str, float], None] | None = None) -> list[ScenarioResult]:
    """Validate every scenario first (bad input stops everything), then run each; a run that
    fails is an ERROR result for that scenario only, and its earlier outputs stay in place."""
    specs = [load_scenario(n, overrides) for n in names]
    results = []
    for spec in specs:
        try:
            run_one(spec, out, _bind(on_progress, spec.name))
            result = evaluate(out / spec.name, baselines)
        except KartciError as err:
            result = ScenarioResult(spec.name, spec.description, error=str(err))
        except Exception as err:  # a crashing controller must not take the suite down
            result = ScenarioResult(spec.name, spec.description,
                                    error=f"run crashed: {type(err).__name__}: {err}")
        results.append(result)
        if on_done is not None:
            on_done(spec.name, result)
    return results


def _bind(cb: Callable[[str, float], None] | None,
          name: str) -> Callable[[float], None] | None:
    if cb is None:
        return None
    return lambda t: cb(name, t)


def rescore(out: Path, baselines: Path) -> list[ScenarioResult]:
    """Recompute every scenario's metrics from its log alone and judge them again."""
    folders = sorted(p.parent for p in out.glob(f"*/{LOG_NAME}"))
    if not folders:
        raise LogError(f"{out}: no <scenario>/{LOG_NAME} logs found")
    results = []
    for folder in folders:
        try:
            score(folder)
            results.append(evaluate(folder, baselines))
        except KartciError as err:
            results.append(ScenarioResult(folder.name, "", error=str(err)))
    return results
