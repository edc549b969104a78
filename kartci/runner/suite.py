"""Run a list of jobs on an executor and gather one result per label, in the order given."""

from __future__ import annotations

import shutil
from pathlib import Path

from kartci.atomic import write_text_atomic
from kartci.core import UNFINISHED, RunFolder
from kartci.project import Project
from kartci.runner import conditioning, costs
from kartci.runner.events import Event, Listener
from kartci.runner.executors import Warm, execute
from kartci.runner.jobs import REPEAT_PREFIX, Context, Draw, Job, Outcome, Refused, Vary
from kartci.runner.kinds import ExecutorKind
from kartci.verdict.result import ScenarioResult


def _ignore(_: Event) -> None:
    pass


def run_jobs(jobs: list[Job], out: Path, baselines: Path, proj: Project, *, workers: int = 1,
             executor: ExecutorKind = ExecutorKind.LOCAL, ray_address: str | None = None,
             timeout_s: float | None = None, strict: bool = False,
             on_event: Listener | None = None, draw: Draw | None = None,
             warm: Warm | None = None) -> list[ScenarioResult]:
    """A run that fails is an ERROR result for its label only (a failed repeat included);
    earlier outputs of a failed run stay in place, marked failed. `strict`: a scenario without
    a baseline, or with a metric its baseline lacks, fails (see runner.gate). `draw`: the
    judged runs' static figures are drawn as each is judged (see jobs.Context). `warm`: worker
    processes kept for the next call (a search's batches; see executors.Warm).

    Every job's folder is marked unfinished before the first run starts, and only that job's
    completed run clears the mark: if this command is interrupted, no older result in OUT can
    pass for one of this command's (report, compare and baseline update refuse marked ones)."""
    emit = on_event or _ignore
    for job in jobs:
        folder = RunFolder(out / job.folder)
        if folder.path.is_dir():
            folder.mark_failed(job.spec.name, UNFINISHED)
    ctx = Context(out, baselines, proj, timeout_s, strict, draw)
    outcomes: dict[str, Outcome] = {}
    for outcome in execute(costs.order(jobs), ctx, emit, workers, executor, ray_address, warm):
        outcomes[outcome.job.folder] = outcome
    costs.remember(outcomes.values())
    results = []
    for job in (j for j in jobs if j.repeat == 0):
        main = outcomes[job.folder]
        result = main.result or ScenarioResult(job.label, job.spec.description, error=main.error)
        mine = [outcomes[j.folder] for j in jobs if j.label == job.label]
        failed = [o for o in mine if o.error and o.job.repeat > 0]
        if result.error is None and failed:
            o = failed[0]
            result = ScenarioResult(job.label, job.spec.description,
                                    error=f"{o.job.folder} (seed {o.job.spec.seed}): {o.error}")
        folder = RunFolder(out / job.label)
        if main.error is None:
            _drop_stale_repeats(folder, {o.job.folder.rsplit("/", 1)[-1] for o in mine})
        if job.vary is Vary.START and len(mine) > 1:
            result = conditioning.judged(result, folder, baselines)
        results.append(result)
    return results


def refused_results(refused: list[Refused], out: Path) -> list[ScenarioResult]:
    """Each refused scenario as an ERROR result, its folder marked failed with the failed
    plugin's own traceback in traceback.txt (the message names the plugin and its error)."""
    results = []
    for r in refused:
        folder = RunFolder(out / r.label)
        folder.path.mkdir(parents=True, exist_ok=True)
        folder.mark_failed(r.label, str(r.error))
        if r.error.trace:
            write_text_atomic(folder.traceback, r.error.trace)
        results.append(ScenarioResult(r.label, "", error=str(r.error)))
    return results


def _drop_stale_repeats(folder: RunFolder, keep: set[str]) -> None:
    """Repeats of an earlier run with a larger --repeat would pollute `compare`'s samples."""
    for old in folder.path.glob(f"{REPEAT_PREFIX}*"):
        if old.is_dir() and old.name not in keep:
            shutil.rmtree(old)
