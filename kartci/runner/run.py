"""Run scenarios into an output folder, score their logs and judge them against baselines.

Layout of OUT: `<scenario>/run.mcap` (the log), `<scenario>/metrics.json` (deterministic),
`<scenario>/run.json` (wall-clock facts), `<scenario>/error.json` (the last run failed), with
`--repeat K` also `<scenario>/repeat_<k>/` (seed + k, same files), and at the top the suite
reports and, for a shard, `shard.json`. A sweep point's folder is `<scenario>@<key>=<value>`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from kartci import geometry, metrics, project
from kartci.errors import KartciError, LogError, SpecError
from kartci.logs import tables
from kartci.metrics import race
from kartci.results import Plots, ScenarioResult
from kartci.sim import simulate
from kartci.spec import Scenario
from kartci.spec.models import HallWorld, line_parts
from kartci.verdict import check_criteria, compare, load, read_metrics, write_json_atomic

LOG_NAME = "run.mcap"
ERROR_NAME = "error.json"  # marks a scenario whose last run failed (older outputs are kept)


def default_baselines() -> Path:
    """The active project's baselines folder."""
    return project.current().baselines


def run_one(scenario: Scenario, out: Path,
            on_progress: Callable[[float], None] | None = None,
            folder: Path | None = None) -> dict[str, Any]:
    """Simulate one scenario into `folder` (default OUT/<scenario>) and score its log; returns
    the run facts (raises KartciError)."""
    folder = folder or out / scenario.name
    t0 = time.perf_counter()
    try:
        info = simulate(scenario, folder / LOG_NAME, on_progress)
    except Exception as err:
        write_json_atomic(folder / ERROR_NAME, {"scenario": scenario.name, "error": str(err)})
        raise
    (folder / ERROR_NAME).unlink(missing_ok=True)
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

    def timing(name: str) -> bool:
        d = metrics.DEFS.get(name.rsplit(".", 1)[-1])
        return d is not None and d.timing

    doc = {"scenario": scenario.name, "seed": scenario.seed,
           "metrics": {name: m.to_json() for name, m in values.items() if not timing(name)},
           "timing": {name: m.to_json() for name, m in values.items() if timing(name)}}
    write_json_atomic(folder / "metrics.json", doc)
    return doc


def plots(folder: Path, scenario: Scenario) -> Plots:
    t = tables(folder / LOG_NAME)
    tracks: dict[str, pd.DataFrame] = {}
    wheels: dict[str, pd.DataFrame] = {}
    commands: dict[str, pd.DataFrame] = {}
    collisions: dict[str, pd.DataFrame] = {}
    is_track = isinstance(scenario.world, HallWorld)
    track = metrics.recorded_track(t, folder / LOG_NAME) if is_track else None
    for agent in scenario.agents:
        odom = t.get(f"/{agent}/odom")
        if odom is not None and not odom.empty:
            if track is not None:
                tracks[agent] = metrics.kart_track(track, odom)
            else:
                tr = metrics.sensor_track(scenario, agent, odom)
                tracks[agent] = tr.assign(speed=tr["vx"])
        js = t.get(f"/{agent}/joint_states")
        if js is not None:
            cols = ([("left", "rear_left_wheel_joint"), ("right", "rear_right_wheel_joint")]
                    if is_track else [("left", "left_wheel_hinge"),
                                      ("right", "right_wheel_hinge")])
            wheels[agent] = pd.DataFrame({"t": js["t"], **{k: js[f"{j}.velocity"]
                                                           for k, j in cols}})
        cmd = t.get(f"/{agent}/wheel_cmd")
        if cmd is not None:
            commands[agent] = pd.DataFrame({"t": cmd["t"],
                                            "left": cmd["left_wheel_hinge.velocity"],
                                            "right": cmd["right_wheel_hinge.velocity"]})
        col = t.get(f"/{agent}/collision")
        if col is not None:
            collisions[agent] = col
    if track is not None:
        world = scenario.world
        assert isinstance(world, HallWorld)
        obstacles = [race.rect(b.center_m[0], b.center_m[1], b.size_m[0], b.size_m[1],
                               b.yaw_rad) for b in world.obstacles]
        horizons, solves = {}, {}
        for agent in scenario.agents:
            plans = t.get(f"/{agent}/mpcc/horizon")
            if plans is not None and len(plans):  # a few moments, evenly spread
                rows = plans.iloc[np.linspace(0, len(plans) - 1, 8).astype(int)[1:]]
                horizons[agent] = [np.column_stack([np.asarray(x, float), np.asarray(y, float)])
                                   for x, y in zip(rows["xs"], rows["ys"], strict=True)]
            stats = t.get(f"/{agent}/mpcc/stats")
            if stats is not None:
                solves[agent] = stats[["t", "solve_ms", "success"]]
        return Plots("track", track.xy, list(track.bounds()), tracks, wheels, commands,
                     collisions, obstacles=obstacles, horizons=horizons, solves=solves)
    world, _ = line_parts(scenario, next(iter(scenario.agents)))
    return Plots("line", np.asarray(geometry.polyline(world.course, 400)), [], tracks, wheels,
                 commands, collisions, scenario.metrics.transient_s)


def evaluate(folder: Path, baselines: Path, with_plots: bool = True) -> ScenarioResult:
    """Judge one scenario folder (metrics.json + log) against its baseline and criteria."""
    name = folder.name
    marker = folder / ERROR_NAME
    if marker.exists():
        try:
            reason = json.loads(marker.read_text(encoding="utf-8")).get("error", "")
        except (OSError, ValueError, AttributeError):
            reason = ""
        return ScenarioResult(name, "", error=f"the last run failed: {reason}".rstrip(": "))
    try:
        scenario, _ = _recorded(folder)
        values = read_metrics(folder / "metrics.json")
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


def check_criteria_names(specs: list[Scenario]) -> None:
    """Criteria must name known metrics: a typo is bad input, found before anything runs."""
    for spec in specs:
        unknown = sorted(
            c for c in spec.criteria if c not in metrics.DEFS and not (
                c.partition(".")[0] in spec.agents and c.partition(".")[2] in metrics.DEFS))
        if unknown:
            raise SpecError(f"scenario {spec.name}: criteria on unknown metrics: "
                            f"{', '.join(unknown)} (known: {', '.join(sorted(metrics.DEFS))})")


def scenario_folders(out: Path) -> list[Path]:
    """The scenario folders of a run: those holding metrics.json or a failed-run marker."""
    return sorted({p.parent for pattern in ("*/metrics.json", f"*/{ERROR_NAME}")
                   for p in out.glob(pattern)})


def rescore(out: Path, baselines: Path) -> list[ScenarioResult]:
    """Recompute every scenario's metrics from its log alone and judge them again."""
    folders = sorted(p.parent for p in out.glob(f"*/{LOG_NAME}"))
    if not folders:
        raise LogError(f"{out}: no <scenario>/{LOG_NAME} logs found")
    results = []
    for folder in folders:
        if (folder / ERROR_NAME).exists():
            results.append(evaluate(folder, baselines))
            continue
        try:
            score(folder)
            results.append(evaluate(folder, baselines))
        except KartciError as err:
            results.append(ScenarioResult(folder.name, "", error=str(err)))
        except Exception as err:  # a log that breaks a reader in a new way: this scenario only
            results.append(ScenarioResult(folder.name, "",
                                          error=f"{type(err).__name__}: {err}"))
    return results
