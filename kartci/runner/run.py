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
import traceback
from collections.abc import Callable, Mapping
from dataclasses import replace
from pathlib import Path
from typing import Any

import pandas as pd

from kartci import core, metrics, portable, project
from kartci.atomic import write_text_atomic
from kartci.core import UNFINISHED, RunFolder
from kartci.errors import KartciError, LogError, SpecError, did_you_mean
from kartci.logs import SCENARIO_TOPIC, tables
from kartci.logs.recorded import COMMANDS, JOY, Recorded
from kartci.plotting import PlotContext, Plots
from kartci.runner.outdir import check_inside, manifest_labels
from kartci.runner.pinned import NotPortable, call_pinned
from kartci.scenario import Scenario
from kartci.scenario.models import LogSource
from kartci.sim import simulate
from kartci.sim.session import describe
from kartci.verdict import Baseline, read_baseline, write_json_atomic
from kartci.verdict.judging import check_allowed, judge_folder
from kartci.verdict.result import ScenarioResult, one_line
from kartci.verdict.trace import load_trace, trace_path


def default_baselines() -> Path:
    """The active project's baselines folder."""
    return project.current().baselines


def mark_failed(folder: Path, name: str, error: str, err: BaseException | None = None) -> None:
    """Mark a scenario folder as failed: its older outputs stay for debugging, but nothing
    (report, compare, baseline update) takes them for this run's. A crash (not a KartciError)
    also leaves its full traceback in traceback.txt; the message itself stays one line."""
    run = RunFolder(folder)
    write_json_atomic(run.error, {"scenario": name, "error": one_line(error)})
    trace = run.traceback
    if err is not None and not isinstance(err, KartciError):
        write_text_atomic(trace, "".join(traceback.format_exception(err)))
    else:
        trace.unlink(missing_ok=True)


def failure_text(err: BaseException) -> str:
    """What a failed run says: a KartciError as it is, anything else as a crash."""
    if isinstance(err, KartciError):
        return str(err)
    return f"run crashed: {type(err).__name__}: {err}"


def run_one(scenario: Scenario, out: Path,
            on_progress: Callable[[float], None] | None = None,
            folder: Path | None = None,
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
    folder = folder or out / scenario.name
    folder.mkdir(parents=True, exist_ok=True)
    for old in RunFolder(folder).stages():  # left by a killed run (OUT is locked)
        shutil.rmtree(old, ignore_errors=True)
    mark_failed(folder, scenario.name, UNFINISHED)
    stage = RunFolder(folder).new_stage().path
    try:
        run = _run_staged(scenario, stage, folder, on_progress, agents, facts)
        _commit(stage, folder)
    except BaseException as err:
        keep_outputs(stage, folder)
        if isinstance(err, Exception | SystemExit):  # Ctrl-C keeps the unfinished mark
            mark_failed(folder, scenario.name, failure_text(err), err)
        raise
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return run


def run_pinned(scenario: Scenario, out: Path, folder: Path,
               agents: Mapping[str, object] | None = None) -> dict[str, Any]:
    """`run_one`, in a pinned child process started as its own command when this process is
    not pinned (kartci.portable, kartci.runner.pinned: the caller's `__main__` is never
    imported again, and an error arrives as the same exception). Agent objects cannot leave
    this process, nor can a scenario naming a class only the caller's `__main__` defines:
    those runs stay here (run.json says so)."""
    if agents or portable.state() is not portable.Pin.UNPINNED:
        return run_one(scenario, out, None, folder, agents)
    try:
        return call_pinned(run_one, scenario, out, None, folder)
    except NotPortable:
        return run_one(scenario, out, None, folder)


def _run_staged(scenario: Scenario, stage: Path, folder: Path,
                on_progress: Callable[[float], None] | None,
                agents: Mapping[str, object] | None = None,
                facts: Mapping[str, Any] | None = None) -> dict[str, Any]:
    t0 = time.perf_counter()
    info = simulate(scenario, RunFolder(stage).log, on_progress, agents)
    wall = time.perf_counter() - t0
    score(stage)
    run: dict[str, Any] = {
        "sim_time_s": round(info.sim_time_s, 6), "wall_s": round(wall, 3),
        "real_time_factor": round(info.sim_time_s / wall, 2) if wall > 0 else None,
        "messages": info.messages, "finished_course": info.finished_course,
        "log": str(RunFolder(folder).log), "platform": portable.describe(), **(facts or {})}
    attach = RunFolder(stage).read_attach()  # how to reach each external stack (its domain)
    if attach:
        run["attach"] = attach
    if agents:
        run["replaced_agents"] = {name: describe(a) for name, a in sorted(agents.items())}
    warnings = input_warnings(scenario)
    if warnings:
        run["warnings"] = warnings
    write_json_atomic(RunFolder(stage).run_record, run)
    return run


def _commit(stage: Path, folder: Path) -> None:
    """Move a complete result into place; the unfinished mark goes last, so a death half-way
    leaves the folder marked."""
    run = RunFolder(folder)
    run.adopt(RunFolder(stage))
    keep_outputs(stage, folder)
    run.traceback.unlink(missing_ok=True)
    run.error.unlink(missing_ok=True)


def keep_outputs(stage: Path, folder: Path) -> None:
    """Controllers' own output files (an external program's stdout and stderr, `*.log`) go to
    the scenario folder whether the run passed or failed: a failed run's are the evidence."""
    for path in stage.glob("*.log"):
        os.replace(path, folder / path.name)


def input_warnings(scenario: Scenario) -> list[str]:
    """Recorded inputs longer than the scenario: the rest is not replayed, which a user must be
    told (not silently cut)."""
    out = []
    for name, agent in scenario.agents.items():
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


def score(folder: Path) -> dict[str, Any]:
    """Compute metrics.json from the log in `folder` (byte-identical for identical logs)."""
    run = RunFolder(folder)
    scenario, values = metrics.compute(run.log)

    def timing(name: str) -> bool:
        d = metrics.definition(name)
        return d is not None and d.timing

    doc = {"scenario": scenario.name, "seed": scenario.seed,
           "metrics": {name: m.to_json() for name, m in values.items() if not timing(name)},
           "timing": {name: m.to_json() for name, m in values.items() if timing(name)}}
    write_json_atomic(run.metrics, doc)
    return doc


def plots(folder: Path, scenario: Scenario) -> Plots | None:
    """The report's time series and geometry, from the log, drawn as the first agent's robot
    kind says (None when the kind draws nothing)."""
    kind = core.ROBOTS.get(next(iter(scenario.agents.values())).model.kind)
    if kind.plots is None:
        return None
    log = RunFolder(folder).log
    result: Plots = kind.plots(PlotContext(scenario, tables(log), log))
    return result


def reference_plots(folder: Path) -> Plots | None:
    """What a reference trace is made of: the plots of a complete run folder."""
    scenario, _ = _recorded(folder)
    return plots(folder, scenario)


def failed_reason(folder: Path) -> str | None:
    """Why a folder's last run failed, or None when it is not marked failed."""
    reason = RunFolder(folder).failure()
    return None if reason is None else f"the last run failed: {one_line(reason)}".rstrip(": ")


def check_finished(out: Path, labels: list[str]) -> None:
    """Refuse (SpecError, naming them all) labels still marked unfinished: the command that
    selected them stopped before their run completed, so their outputs are an older run's."""
    late = [label for label in labels if RunFolder(out / label).unfinished()]
    if late:
        one = len(late) == 1
        raise SpecError(f"{', '.join(late)}: not finished in {out} (the command that selected "
                        f"{'it' if one else 'them'} was interrupted); run {'it' if one else 'them'}"
                        " again")


def check_complete(folder: Path) -> None:
    """A folder whose outputs are one complete, current run (raises SpecError otherwise): what
    `baseline update` may promote."""
    if not folder.is_dir():
        raise SpecError(f"{folder}: no such scenario folder")
    reason = failed_reason(folder)
    if reason is not None:
        why = reason.removeprefix("the last run failed").lstrip(": ")
        raise SpecError(f"{folder}: the last run of this scenario failed"
                        f"{f' ({why})' if why else ''}; its metrics are stale and will not "
                        "become a baseline")
    missing = RunFolder(folder).missing()
    if missing:
        raise SpecError(f"{folder}: incomplete (no {' or '.join(missing)}); run it again")


def evaluate(folder: Path, baselines: Path, with_plots: bool = True) -> ScenarioResult:
    """Judge one scenario folder (metrics.json + log) against its baseline and criteria.

    A folder that cannot be judged (log, metrics or plots unreadable) is marked failed, so that
    nothing promotes or compares its outputs later; a bad baseline file is the baseline's fault
    and leaves the folder as it is."""
    name = folder.name
    reason = failed_reason(folder)
    if reason is not None:
        return ScenarioResult(name, "", error=reason)
    try:
        baseline = read_baseline(baselines / f"{name}.json")
        reference = load_trace(trace_path(baselines, name)) if with_plots else {}
    except KartciError as err:
        return ScenarioResult(name, "", error=str(err))
    try:
        return _judge(folder, baseline, with_plots, reference)
    except Exception as err:  # this scenario only: the others are still judged
        error = str(err) if isinstance(err, KartciError) else (
            f"cannot judge {name}: {type(err).__name__}: {err}")
        if folder.is_dir():
            mark_failed(folder, name, error, err)
        return ScenarioResult(name, "", error=one_line(error))


def _judge(folder: Path, baseline: Baseline | None, with_plots: bool,
           reference: dict[str, pd.DataFrame]) -> ScenarioResult:
    scenario, _ = _recorded(folder)
    result = judge_folder(RunFolder(folder), scenario, baseline)
    drawn = plots(folder, scenario) if with_plots else None
    if drawn is not None:
        drawn = replace(drawn, reference=reference)
    return replace(result, plots=drawn)


def recorded_scenario(folder: Path) -> Scenario:
    """The scenario a run folder's log recorded: exactly what ran, overrides applied."""
    return _recorded(folder)[0]


def _recorded(folder: Path) -> tuple[Scenario, dict[str, pd.DataFrame]]:
    log = RunFolder(folder).log
    t = tables(log, [SCENARIO_TOPIC])
    return metrics.recorded_scenario(t, log), t


def check_criteria_names(specs: list[Scenario]) -> None:
    """Criteria must name known metrics, and so must the project's allowed loose tolerances
    (check_allowed): a typo is bad input, found before anything runs."""
    check_allowed()
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


def scenario_folders(out: Path) -> list[Path]:
    """The scenario folders of a run: those holding metrics.json or a failed-run marker."""
    return sorted({p.parent for pattern in (f"*/{RunFolder.METRICS_NAME}",
                                            f"*/{RunFolder.ERROR_NAME}")
                   for p in out.glob(pattern)})


def rescore(out: Path, baselines: Path) -> list[ScenarioResult]:
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
    check_allowed()
    return [_rescore_one(out / name, baselines) for name in sorted(names)]


def _rescore_one(folder: Path, baselines: Path) -> ScenarioResult:
    if failed_reason(folder) is not None:
        return evaluate(folder, baselines)
    if not folder.is_dir():
        return ScenarioResult(folder.name, "", error=f"{folder}: the scenario folder is missing")
    try:
        log = RunFolder(folder).log
        if not log.is_file():
            raise LogError(f"{log}: missing; nothing to score")
        score(folder)
    except Exception as err:  # a log that breaks a reader in a new way: this scenario only
        error = str(err) if isinstance(err, KartciError) else f"{type(err).__name__}: {err}"
        mark_failed(folder, folder.name, error, err)
        return ScenarioResult(folder.name, "", error=one_line(error))
    return evaluate(folder, baselines)
