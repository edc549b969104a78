"""Run scenarios into an output folder, score their logs and judge them against baselines.

Layout of OUT: `<scenario>/run.mcap` (the log), `<scenario>/metrics.json` (deterministic),
`<scenario>/run.json` (wall-clock facts), `<scenario>/error.json` (the last run failed), with
`--repeat K` also `<scenario>/repeat_<k>/` (seed + k, same files), and at the top the suite
reports and, for a shard, `shard.json`. A sweep point's folder is `<scenario>@<key>=<value>`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from kartci import metrics, plugins, project
from kartci.errors import KartciError, LogError, SpecError
from kartci.logs import tables
from kartci.project import did_you_mean
from kartci.report.data import PlotContext
from kartci.results import Plots, ScenarioResult
from kartci.sim import simulate
from kartci.sim.session import describe
from kartci.spec import Scenario
from kartci.verdict import check_criteria, compare, load, read_metrics, write_json_atomic

LOG_NAME = "run.mcap"
ERROR_NAME = "error.json"  # marks a scenario whose last run failed (older outputs are kept)


def default_baselines() -> Path:
    """The active project's baselines folder."""
    return project.current().baselines


def run_one(scenario: Scenario, out: Path,
            on_progress: Callable[[float], None] | None = None,
            folder: Path | None = None,
            agents: Mapping[str, object] | None = None) -> dict[str, Any]:
    """Simulate one scenario into `folder` (default OUT/<scenario>) and score its log; returns
    the run facts (raises KartciError). `agents`: objects replacing those agents' controllers
    (recorded in the log and in run.json as `replaced_agents`)."""
    folder = folder or out / scenario.name
    t0 = time.perf_counter()
    try:
        info = simulate(scenario, folder / LOG_NAME, on_progress, agents)
    except Exception as err:
        write_json_atomic(folder / ERROR_NAME, {"scenario": scenario.name, "error": str(err)})
        raise
    (folder / ERROR_NAME).unlink(missing_ok=True)
    wall = time.perf_counter() - t0
    score(folder)
    run: dict[str, Any] = {
        "sim_time_s": round(info.sim_time_s, 6), "wall_s": round(wall, 3),
        "real_time_factor": round(info.sim_time_s / wall, 2) if wall > 0 else None,
        "messages": info.messages, "finished_course": info.finished_course,
        "log": str(folder / LOG_NAME)}
    if agents:
        run["replaced_agents"] = {name: describe(a) for name, a in sorted(agents.items())}
    write_json_atomic(folder / "run.json", run)
    return run


def score(folder: Path) -> dict[str, Any]:
    """Compute metrics.json from the log in `folder` (byte-identical for identical logs)."""
    scenario, values = metrics.compute(folder / LOG_NAME)

    def timing(name: str) -> bool:
        d = metrics.definition(name)
        return d is not None and d.timing

    doc = {"scenario": scenario.name, "seed": scenario.seed,
           "metrics": {name: m.to_json() for name, m in values.items() if not timing(name)},
           "timing": {name: m.to_json() for name, m in values.items() if timing(name)}}
    write_json_atomic(folder / "metrics.json", doc)
    return doc


def plots(folder: Path, scenario: Scenario) -> Plots | None:
    """The report's time series and geometry, from the log, drawn as the first agent's robot
    kind says (None when the kind draws nothing)."""
    kind = plugins.ROBOTS.get(next(iter(scenario.agents.values())).model.kind)
    if kind.plots is None:
        return None
    result: Plots = kind.plots(PlotContext(scenario, tables(folder / LOG_NAME),
                                           folder / LOG_NAME))
    return result


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
    defs = metrics.definitions()
    for spec in specs:
        unknown = sorted(
            c for c in spec.criteria if c not in defs and not (
                c.partition(".")[0] in spec.agents and c.partition(".")[2] in defs))
        if unknown:
            raise SpecError(f"scenario {spec.name}: criteria on unknown metrics: "
                            f"{', '.join(unknown)}{did_you_mean(unknown[0], defs)}")


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
