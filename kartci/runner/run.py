"""Run scenarios into an output folder, score their logs and judge them against baselines.

Layout of OUT: `<scenario>/run.mcap` (the log), `<scenario>/metrics.json` (deterministic),
`<scenario>/run.json` (wall-clock facts), `<scenario>/error.json` (the last run failed), with
`--repeat K` also `<scenario>/repeat_<k>/` (seed + k, same files), and at the top the suite
reports and, for a shard, `shard.json`. A sweep point's folder is `<scenario>@<key>=<value>`.
"""

from __future__ import annotations

import math
import os
import shutil
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import pandas as pd

from kartci import core, metrics, portable
from kartci.core import UNFINISHED, RunFolder
from kartci.errors import KartciError, LogError, SpecError, did_you_mean, one_line
from kartci.logs import SCENARIO_TOPIC, tables
from kartci.logs.recorded import COMMANDS, JOY, Recorded
from kartci.plotting import PlotContext, Plots
from kartci.project import Project
from kartci.runner.outdir import check_inside, manifest_labels
from kartci.runner.pinned import NotPortable, call_pinned
from kartci.scenario import Scenario
from kartci.scenario.models import LogSource
from kartci.sim import simulate
from kartci.sim.session import describe
from kartci.verdict import Baseline, read_baseline, write_json_atomic
from kartci.verdict.judging import check_allowed, judge_folder
from kartci.verdict.result import ScenarioResult
from kartci.verdict.trace import load_trace, trace_path


def failure_text(err: BaseException) -> str:
    """What a failed run says: a KartciError as it is, anything else as a crash."""
    if isinstance(err, KartciError):
        return str(err)
    return f"run crashed: {type(err).__name__}: {err}"


def run_one(scenario: Scenario, out: Path,
            on_progress: Callable[[float], None] | None = None,
            folder: RunFolder | None = None,
            agents: Mapping[str, object] | None = None,
            facts: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """Simulate one scenario into `folder` (default OUT/<scenario>) and score its log; returns
    the run facts (raises on failure, with the folder marked failed). `agents`: objects
    replacing those agents' controllers (recorded in the log and in run.json as
    `replaced_agents`). `facts`: more entries for run.json.

    The folder is marked unfinished first, the run and its scoring happen in a private staging
    folder, and only a complete result (log, metrics, facts) replaces the previous one: a run
    that fails anywhere, or whose process dies, never destroys the previous good log and always
    leaves the folder marked."""
    folder = folder or RunFolder(out / scenario.name)
    folder.path.mkdir(parents=True, exist_ok=True)
    for old in folder.stages():  # left by a killed run (OUT is locked)
        shutil.rmtree(old, ignore_errors=True)
    folder.mark_failed(scenario.name, UNFINISHED)
    stage = folder.new_stage()
    try:
        run = _run_staged(scenario, stage, folder, on_progress, agents, facts)
        _commit(stage, folder)
    except BaseException as err:
        keep_outputs(stage, folder)
        if isinstance(err, Exception | SystemExit):  # Ctrl-C keeps the unfinished mark
            folder.mark_failed(scenario.name, failure_text(err), err)
        raise
    finally:
        shutil.rmtree(stage.path, ignore_errors=True)
    return run


def run_pinned(scenario: Scenario, out: Path, folder: RunFolder,
               agents: Mapping[str, object] | None = None) -> dict[str, Any]:
    """`run_one`, in a pinned child process started as its own command when this process is
    not pinned (kartci.portable, kartci.runner.pinned: the caller's `__main__` is never
    imported again, and an error arrives as the same exception). Agent objects cannot leave
    this process, nor can a scenario naming a class only the caller's `__main__` defines:
    those runs stay here (run.json says so)."""
    if agents or portable.state() is not portable.Pin.UNPINNED:
        return run_one(scenario, out, None, folder, agents)
    try:
        return call_pinned(scenario.project, run_one, scenario, out, None, folder)
    except NotPortable:
        return run_one(scenario, out, None, folder)


def _run_staged(scenario: Scenario, stage: RunFolder, folder: RunFolder,
                on_progress: Callable[[float], None] | None,
                agents: Mapping[str, object] | None = None,
                facts: Mapping[str, Any] | None = None) -> dict[str, Any]:
    t0 = time.perf_counter()
    info = simulate(scenario, stage.log, on_progress, agents)
    wall = time.perf_counter() - t0
    score(stage)
    run: dict[str, Any] = {
        "sim_time_s": round(info.sim_time_s, 6), "wall_s": round(wall, 3),
        "real_time_factor": round(info.sim_time_s / wall, 2) if wall > 0 else None,
        "messages": info.messages, "finished_course": info.finished_course,
        "log": str(folder.log), "platform": portable.describe(), **(facts or {})}
    attach = stage.read_attach()  # how to reach each external stack (its domain)
    if attach:
        run["attach"] = attach
    if agents:
        run["replaced_agents"] = {name: describe(a) for name, a in sorted(agents.items())}
    warnings = input_warnings(scenario)
    if warnings:
        run["warnings"] = warnings
    write_json_atomic(stage.run_record, run)
    return run


def _commit(stage: RunFolder, folder: RunFolder) -> None:
    """Move a complete result into place; the unfinished mark goes last, so a death half-way
    leaves the folder marked."""
    folder.adopt(stage)
    keep_outputs(stage, folder)
    folder.traceback.unlink(missing_ok=True)
    folder.error.unlink(missing_ok=True)


def keep_outputs(stage: RunFolder, folder: RunFolder) -> None:
    """Controllers' own output files (an external program's stdout and stderr, `*.log`) go to
    the scenario folder whether the run passed or failed: a failed run's are the evidence."""
    for path in stage.path.glob("*.log"):
        os.replace(path, folder.path / path.name)


def input_warnings(scenario: Scenario) -> list[str]:
    """Recorded inputs longer than the scenario: the rest is not replayed, which a user must be
    told (not silently cut); and what each agent's robot kind warns of (`RobotKind.warnings`)."""
    out = []
    for name, agent in scenario.agents.items():
        warn = core.ROBOTS.get(agent.model.kind).warnings
        if warn is not None:
            out += [f"{name}: {w}" for w in warn(agent.model, agent.controller, scenario.world)]
        source = getattr(agent.controller, "source", None)
        if not isinstance(source, LogSource):
            continue
        try:
            rec = Recorded(source, (*JOY, *COMMANDS))
        except KartciError:  # the agent itself reports an unusable log
            continue
        end_s = rec.times[-1] * 1e-9
        if end_s > scenario.duration_s + 1e-9:
            out.append(f"{name}: the input log {rec.topic} runs to {end_s:.1f} s but the "
                       f"scenario stops at {scenario.duration_s:g} s; the last "
                       f"{end_s - scenario.duration_s:.1f} s are not replayed (set "
                       f"duration_s={math.ceil(end_s)} to replay all of it)")
    return out


def score(folder: RunFolder) -> dict[str, Any]:
    """Compute metrics.json from the log in `folder` (byte-identical for identical logs)."""
    scenario, values = metrics.compute(folder.log)

    def timing(name: str) -> bool:
        d = metrics.definition(name)
        return d is not None and d.timing

    doc = {"scenario": scenario.name, "seed": scenario.seed,
           "metrics": {name: m.to_json() for name, m in values.items() if not timing(name)},
           "timing": {name: m.to_json() for name, m in values.items() if timing(name)}}
    write_json_atomic(folder.metrics, doc)
    return doc


def plots(folder: RunFolder, scenario: Scenario) -> Plots | None:
    """The report's time series and geometry, from the log, drawn as the first agent's robot
    kind says (None when the kind draws nothing)."""
    kind = core.ROBOTS.get(next(iter(scenario.agents.values())).model.kind)
    if kind.plots is None:
        return None
    log = folder.log
    result: Plots = kind.plots(PlotContext(scenario, tables(log), log))
    return result


def reference_plots(folder: RunFolder) -> Plots | None:
    """What a reference trace is made of: the plots of a complete run folder."""
    scenario, _ = _recorded(folder)
    return plots(folder, scenario)


def check_finished(out: Path, labels: list[str]) -> None:
    """Refuse (SpecError, naming them all) labels still marked unfinished: the command that
    selected them stopped before their run completed, so their outputs are an older run's."""
    late = [label for label in labels if RunFolder(out / label).unfinished()]
    if late:
        one = len(late) == 1
        raise SpecError(f"{', '.join(late)}: not finished in {out} (the command that selected "
                        f"{'it' if one else 'them'} was interrupted); run {'it' if one else 'them'}"
                        " again")


def evaluate(folder: RunFolder, baselines: Path, proj: Project, with_plots: bool = True
             ) -> ScenarioResult:
    """Judge one scenario folder (metrics.json + log) against its baseline in `baselines` and
    its criteria, by `proj`'s tolerance policy.

    A folder that cannot be judged (log, metrics or plots unreadable) is marked failed, so that
    nothing promotes or compares its outputs later; a bad baseline file is the baseline's fault
    and leaves the folder as it is."""
    name = folder.name
    reason = folder.failed_reason()
    if reason is not None:
        return ScenarioResult(name, "", error=reason)
    try:
        baseline = read_baseline(baselines / f"{name}.json")
        reference = load_trace(trace_path(baselines, name)) if with_plots else {}
    except KartciError as err:
        return ScenarioResult(name, "", error=str(err))
    try:
        return _judge(folder, baseline, proj, with_plots, reference)
    except Exception as err:  # this scenario only: the others are still judged
        error = str(err) if isinstance(err, KartciError) else (
            f"cannot judge {name}: {type(err).__name__}: {err}")
        if folder.path.is_dir():
            folder.mark_failed(name, error, err)
        return ScenarioResult(name, "", error=one_line(error))


def _judge(folder: RunFolder, baseline: Baseline | None, proj: Project, with_plots: bool,
           reference: dict[str, pd.DataFrame]) -> ScenarioResult:
    scenario, _ = _recorded(folder)
    result = judge_folder(folder, scenario, baseline, proj)
    drawn = plots(folder, scenario) if with_plots else None
    if drawn is not None:
        drawn = replace(drawn, reference=reference)
    return replace(result, plots=drawn)


def recorded_scenario(folder: RunFolder) -> Scenario:
    """The scenario a run folder's log recorded: exactly what ran, overrides applied."""
    return _recorded(folder)[0]


def _recorded(folder: RunFolder) -> tuple[Scenario, dict[str, pd.DataFrame]]:
    log = folder.log
    t = tables(log, [SCENARIO_TOPIC])
    return metrics.recorded_scenario(t, log), t


def check_criteria_names(specs: list[Scenario], proj: Project) -> None:
    """Criteria must name known metrics, and so must `proj`'s allowed loose tolerances
    (check_allowed): a typo is bad input, found before anything runs."""
    check_allowed(proj)
    defs = metrics.definitions()
    for spec in specs:
        unknown = sorted(
            c for c in spec.criteria if c not in defs and not (
                c.partition(".")[0] in spec.agents and c.partition(".")[2] in defs))
        if unknown:  # the nearest metric, or agent.metric for a misspelt agent's
            hint = did_you_mean(unknown[0], [*defs, *(f"{a}.{m}" for a in spec.agents
                                                      for m in defs)])
            if not hint.startswith(" (did you mean"):
                hint = did_you_mean(unknown[0], defs)  # the metrics known, not every agent's
            raise SpecError(f"scenario {spec.name}: criteria on unknown metrics: "
                            f"{', '.join(unknown)}{hint}")


def scenario_folders(out: Path) -> list[RunFolder]:
    """The scenario folders of a run: those holding metrics.json or a failed-run marker."""
    return [RunFolder(path) for path in sorted(
        {p.parent for pattern in (f"*/{RunFolder.METRICS_NAME}", f"*/{RunFolder.ERROR_NAME}")
         for p in out.glob(pattern)})]


def rescore(out: Path, baselines: Path, proj: Project) -> list[ScenarioResult]:
    """Recompute every scenario's metrics from its log alone and judge them again: those of the
    last run in OUT (its manifest), else every folder with a log, metrics or a failure mark.
    Each gets a result: one whose log is gone or damaged is an error, its folder marked."""
    names = set(manifest_labels(out) or []) or {
        p.parent.name for name in (RunFolder.LOG_NAME, RunFolder.METRICS_NAME,
                                   RunFolder.ERROR_NAME)
        for p in out.glob(f"*/{name}")}
    if not names:
        raise LogError(f"{out}: no <scenario>/{RunFolder.LOG_NAME} logs found")
    check_inside(out, names)
    check_allowed(proj)
    return [_rescore_one(RunFolder(out / name), baselines, proj) for name in sorted(names)]


def _rescore_one(folder: RunFolder, baselines: Path, proj: Project) -> ScenarioResult:
    if folder.failed_reason() is not None:
        return evaluate(folder, baselines, proj)
    if not folder.path.is_dir():
        return ScenarioResult(folder.name, "",
                              error=f"{folder.path}: the scenario folder is missing")
    try:
        log = folder.log
        if not log.is_file():
            raise LogError(f"{log}: missing; nothing to score")
        score(folder)
    except Exception as err:  # a log that breaks a reader in a new way: this scenario only
        error = str(err) if isinstance(err, KartciError) else f"{type(err).__name__}: {err}"
        folder.mark_failed(folder.name, error, err)
        return ScenarioResult(folder.name, "", error=one_line(error))
    return evaluate(folder, baselines, proj)
