"""Units of work: one simulation of one scenario into one folder, picklable for any executor.

A *label* names a scenario result and its folder in OUT: the scenario name, or for a sweep
point `<scenario>@<key>=<value>`. With `--repeat K`, replica k (k = 1 .. K-1) runs into
`<label>/repeat_<k>/` beside the judged run in `<label>/`: with seed + k (`Vary.SEED`, the
spread of the noise), or with every robot's start moved k nanometres sideways (`Vary.START`,
`--conditioning K`: the spread of chaos, which the baseline records).
"""

from __future__ import annotations

import itertools
import math
import re
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from types import FrameType
from typing import Any

from kartci.core import RunFolder
from kartci.errors import PluginError, RunError, SpecError, one_line
from kartci.plotting import Plots
from kartci.project import Project, held
from kartci.runner.gate import require_baselines
from kartci.runner.run import (
    check_criteria_names,
    evaluate,
    failure_text,
    run_one,
)
from kartci.scenario import Scenario, load_scenario
from kartci.scenario.load import scenario_loader
from kartci.scenario.yamlio import clip
from kartci.verdict.result import ScenarioResult

REPEAT_PREFIX = "repeat_"
START_STEP_M = 1e-9  # replica k starts k x 1 nm to the left: far below anything physical
Report = Callable[[str, float], None]  # (job folder, sim time s), called from the worker
Progress = Callable[[int, int], None]  # (sweep points validated, points in all)
# a result's figures drawn as SVG for report-static.html (kartci.report.static.scenario_svgs,
# passed in by the command, which sits above both runner and report)
Draw = Callable[[Plots], tuple[str, ...]]
Grid = list[tuple[str, list[str]]]  # a sweep: (dotted key, its values) per axis
# The one cap on every count a user gives (sweep points, --repeat, --conditioning, --replicas,
# --jobs, and their products): each unit is a run, a folder in OUT, a process or a baseline of
# its own, and 10,000 runs are already hours of CI and a minute of validation; a larger count is
# a mistake or belongs split over several commands (`--shard` splits the runs, not this).
MAX_RUNS = 10_000
REPORT_EVERY_S = 1.0  # sim time between a job's progress reports, s


class Vary(StrEnum):
    """What a replica changes."""

    SEED = "seed"  # seed + k: another draw of the sensor noise
    START = "start"  # every robot's start k x START_STEP_M to the left: a last-bit nudge


def drives_a_stack(spec: Scenario) -> bool:
    """Whether an agent of the scenario is an external stack (its nodes' timing is its noise)."""
    return any(a.controller.type == "external" for a in spec.agents.values())


def replica(spec: Scenario, vary: Vary, k: int) -> Scenario:
    """Replica k of a scenario (k = 0 is the scenario itself). A start replica of a scenario
    that drives an external stack is the scenario itself: the stack's timing varies between
    repeats, and a lockstep that is deterministic gives the same numbers every time."""
    if k == 0 or (vary is Vary.START and drives_a_stack(spec)):
        return spec
    if vary is Vary.SEED:
        return spec.model_copy(update={"seed": spec.seed + k})
    agents = {name: a.model_copy(update={"start": a.start.model_copy(update={
        "lateral_m": a.start.lateral_m + k * START_STEP_M})}) for name, a in spec.agents.items()}
    return spec.model_copy(update={"agents": agents})


@dataclass(frozen=True)
class Job:
    """One simulation: a validated scenario, the label it is reported under, its repeat index."""

    spec: Scenario
    label: str  # the scenario result's name and top-level folder
    repeat: int = 0  # k: replica k; 0 is the judged run
    vary: Vary = Vary.SEED  # what replicas change

    @property
    def variation(self) -> dict[str, Any]:
        """What this run changed, for run.json (baseline update reads it)."""
        step = (0.0 if drives_a_stack(self.spec) else START_STEP_M) if (
            self.vary is Vary.START) else 1
        return {"vary": self.vary.value, "k": self.repeat, "step": step}

    @property
    def folder(self) -> str:
        """The job's folder relative to OUT: `<label>`, or `<label>/repeat_<k>` for a repeat."""
        return self.label if self.repeat == 0 else f"{self.label}/{REPEAT_PREFIX}{self.repeat}"


@dataclass(frozen=True)
class Outcome:
    """How a job ended: its error, or the judged result (repeat 0 only), and its run.json facts."""

    job: Job
    error: str | None = None
    result: ScenarioResult | None = None  # the judged run (repeat 0) only
    run: dict[str, Any] = field(default_factory=dict)  # run.json facts
    job_s: float = 0.0  # wall time of the whole job (simulate, score, judge, draw), s

    @classmethod
    def failed(cls, job: Job, error: str) -> Outcome:
        """A job that failed with `error`; the judged run gets an errored result, so its scenario is
        still reported."""
        return cls(job, error, ScenarioResult(job.label, job.spec.description, error=error)
                   if job.repeat == 0 else None)


@dataclass(frozen=True)
class Context:
    """What every job of one `kartci run` shares."""

    out: Path
    baselines: Path
    project: Project  # the parent's: workers import its plugins and judge by its policy
    timeout_s: float | None = None
    strict: bool = False  # a missing baseline or baseline metric fails (see runner.gate)
    # draws the judged run's figures where it was judged: in a worker with -j N, so drawing
    # overlaps other runs instead of following the last one (None: the report draws them)
    draw: Draw | None = None


def parse_sweep(text: str) -> tuple[str, list[str]]:
    """`--sweep dotted.key=v1,v2,...` as the key and its values."""
    key, sep, values = text.partition("=")
    items = [v.strip() for v in values.split(",") if v.strip()]
    if not sep or not key.strip() or not items:
        raise SpecError(f"--sweep {text!r}: expected dotted.key=v1,v2,...")
    return key.strip(), items


def _safe(text: str) -> str:
    """Folder-name safe and still readable: `/`, spaces and the like become `_`."""
    return re.sub(r"[^A-Za-z0-9_.=@+,-]", "_", text)


@dataclass(frozen=True)
class Refused:
    """A scenario that cannot run here: it names a plugin that failed to load. It is reported
    as an error of its own while the other scenarios run."""

    label: str  # its result's name and folder
    error: PluginError


def plugin_failure(err: BaseException) -> PluginError | None:
    """The failed plugin behind a scenario's validation error, if that is what it is."""
    seen: BaseException | None = err
    while seen is not None and not isinstance(seen, PluginError):
        seen = seen.__cause__
    return seen


def runnable(names: list[str], overrides: list[str], proj: Project, *,
             allow_outside_paths: bool = False) -> tuple[list[str], list[Refused]]:
    """The scenarios that can run, and those refused because a plugin they name failed to
    load; any other problem is bad input that stops everything, as in `expand`."""
    keep: list[str] = []
    refused: list[Refused] = []
    for name in names:
        try:
            load_scenario(name, overrides, project=proj,
                          allow_outside_paths=allow_outside_paths)
        except SpecError as err:
            cause = plugin_failure(err)
            if cause is None:
                raise
            stem = Path(name).stem if name.endswith((".yaml", ".yml")) else name
            refused.append(Refused(_safe(stem + _variant(overrides, [])),
                                   PluginError(str(err), cause.trace)))
            continue
        keep.append(name)
    return keep, refused


def expand(names: list[str], overrides: list[str], proj: Project,
           sweeps: list[str] | None = None, repeat: int = 1, vary: Vary = Vary.SEED,
           progress: Progress | None = None, *, allow_outside_paths: bool = False) -> list[Job]:
    """Every job of a run, all validated before anything runs (bad input stops everything);
    data files resolved once here, so workers never look a path up again.

    A sweep's points are validated one by one, each reported to `progress` (points validated,
    points in all); a grid of more than MAX_RUNS fails before any is expanded."""
    if repeat < 1:
        raise SpecError(f"--repeat {repeat}: expected 1 or more")
    axes = [parse_sweep(s) for s in sweeps or []]
    grids = [(name, axes or [(k, [str(v) for v in vs]) for k, vs in
                             load_scenario(name, overrides, project=proj,
                                           allow_outside_paths=
                                           allow_outside_paths).sweep.items()])
             for name in names]
    total = sum(_checked_size(name, grid) for name, grid in grids)
    if total * repeat > MAX_RUNS:  # each replica is a run of its own
        raise SpecError(f"{total:,} runs x {repeat:,} replicas = {total * repeat:,} runs, "
                        f"more than the {MAX_RUNS:,} allowed; split the command")
    jobs = _points(grids, overrides, proj, repeat, vary, (total, progress),
                   allow_outside_paths)
    check_criteria_names([j.spec for j in jobs if j.repeat == 0], proj)
    return jobs


def _points(grids: list[tuple[str, Grid]], overrides: list[str], proj: Project,
            repeat: int, vary: Vary, report: tuple[int, Progress | None],
            allow_outside_paths: bool) -> list[Job]:
    """The jobs of every grid point, each validated as it comes (a duplicate label is found
    in a set, not by counting in a list)."""
    jobs: list[Job] = []
    labels: set[str] = set()
    done, (total, progress) = 0, report
    for name, grid in grids:
        load = scenario_loader(name, project=proj, allow_outside_paths=allow_outside_paths)
        for point in itertools.product(*[[(k, v) for v in values] for k, values in grid]):
            spec = load([*overrides, *(f"{k}={v}" for k, v in point)])
            label = point_label(spec.name, overrides, list(point))
            if label in labels:
                raise SpecError(f"scenario selected twice: {label}")
            labels.add(label)
            jobs += [Job(replica(spec, vary, k), label, k, vary) for k in range(repeat)]
            done += 1
            if progress is not None:
                progress(done, total)
    return jobs


def check_count(option: str, value: int) -> None:
    """SpecError (one line) when a count a user gave exceeds MAX_RUNS: called before any work,
    so `--replicas 1000000000` fails at once instead of building a billion jobs."""
    if value > MAX_RUNS:
        raise SpecError(f"{option} {value:,}: more than the {MAX_RUNS:,} allowed")


def point_label(name: str, overrides: list[str], point: list[tuple[str, str]]) -> str:
    """The label (and folder) of a scenario run at a point of a sweep or a search:
    `<scenario>@<key>=<value>,...`, folder-name safe."""
    return _safe(name + _variant(overrides, point))


def _checked_size(name: str, grid: Grid) -> int:
    """The number of points of a scenario's grid, from the axis lengths alone; more than
    MAX_RUNS is an error."""
    count = math.prod(len(values) for _, values in grid)
    if count > MAX_RUNS:
        shown = f"{count:,}" if count < 10**15 else f"about 10^{int(math.log10(count))}"
        raise SpecError(f"scenario {clip(name)}: sweep: {shown} points, more than the "
                        f"{MAX_RUNS:,} allowed; split the sweep")
    return count


def default_suite(paths: list[Path], proj: Project, allow_outside_paths: bool = False
                  ) -> list[str]:
    """The scenarios a plain `kartci run` runs: all but `tool` ones and grids (a scenario with
    its own sweep), which run by name; one that names a plugin that failed to load is kept
    (it is reported as failed, see `runnable`)."""
    return [p.stem for p in paths if _in_default_suite(p.stem, proj, allow_outside_paths)]


def _in_default_suite(name: str, proj: Project, allow_outside_paths: bool) -> bool:
    try:
        spec = load_scenario(name, project=proj, allow_outside_paths=allow_outside_paths)
    except SpecError as err:
        if plugin_failure(err) is None:
            raise
        return True
    return "tool" not in spec.tags and not spec.sweep


def _variant(overrides: list[str], point: list[tuple[str, str]]) -> str:
    """The label suffix of a run that is not the scenario as written: a sweep point, or a world
    or track given with `--set` (a run on another track is judged against that track's own
    baseline, `<scenario>@track=<name>`, never the original's)."""
    parts = [f"{k}={v}" for k, v in point]
    for assignment in overrides:
        key, _, value = assignment.partition("=")
        key, value = key.strip(), value.strip()
        if key == "world.track" and "world.track" not in dict(point):
            parts.insert(0, f"track={Path(value).stem}")
        elif key == "world" and "world" not in dict(point):
            parts.insert(0, f"world={value}")
    return "@" + ",".join(parts) if parts else ""


def parse_shard(text: str) -> tuple[int, int]:
    """`--shard I/N` as (I, N), 1 <= I <= N."""
    index, sep, total = text.partition("/")
    try:
        i, n = int(index), int(total)
    except ValueError:
        i = n = 0
    if not sep or not 1 <= i <= n:
        raise SpecError(f"--shard {text!r}: expected I/N with 1 <= I <= N, e.g. 1/4")
    return i, n


def shard(jobs: list[Job], index: int, total: int) -> list[Job]:
    """Shard `index` of `total` (1-based): labels sorted by name, dealt round-robin, so every
    shard gets the same count (±1) and a label with its repeats stays on one shard."""
    mine = shard_labels({j.label for j in jobs}, index, total)
    return [j for j in jobs if j.label in mine]


def shard_labels(labels: set[str], index: int, total: int) -> set[str]:
    """The labels of shard `index` of `total`: sorted, dealt round-robin."""
    return {label for i, label in enumerate(sorted(labels)) if i % total == index - 1}


@contextmanager
def wall_clock_limit(limit_s: float | None, where: Callable[[], str]) -> Iterator[None]:
    """Bound the enclosed work in wall-clock time, wherever it is.

    An interval timer (SIGALRM) interrupts the main thread of the process running the job,
    even inside a controller step that sleeps or spins in Python, and raises RunError there;
    it fires again every second in case a controller swallows the exception. Native code
    (one PyBullet call) is interrupted when it returns. Off the main thread (a Ray worker
    thread) or without SIGALRM (Windows) only the check at each progress report applies."""
    usable = (limit_s is not None and hasattr(signal, "setitimer")
              and threading.current_thread() is threading.main_thread())
    if not usable or limit_s is None:
        yield
        return
    armed = [True]

    def expire(signum: int, frame: FrameType | None) -> None:
        if armed[0]:
            raise RunError(f"time limit: over {limit_s:g} s wall clock ({where()})")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_REAL, limit_s, 1.0)
    try:
        yield
    finally:
        armed[0] = False
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_job(job: Job, ctx: Context, report: Report | None = None) -> Outcome:
    """Simulate, score and (for the judged run) evaluate one job; never raises for a failed run,
    so one crashing scenario cannot take the others down. Runs in any process, in the project
    `ctx` carries (whose plugins the registries load: a worker's own working directory may be
    another project's, or none)."""
    with held(ctx.project):
        return _run_job(job, ctx, report)


def _run_job(job: Job, ctx: Context, report: Report | None) -> Outcome:
    start = time.perf_counter()
    sim_t = [0.0, 0.0]  # the sim time reached, and when it was last reported, s

    def where() -> str:
        return f"at sim time {sim_t[0]:.3g} s"

    def progress(t: float) -> None:
        sim_t[0] = t
        if ctx.timeout_s is not None and time.perf_counter() - start > ctx.timeout_s:
            raise RunError(f"time limit: over {ctx.timeout_s:g} s wall clock ({where()})")
        if report is not None and t - sim_t[1] >= REPORT_EVERY_S:
            sim_t[1] = t
            report(job.folder, t)

    folder = RunFolder(ctx.out / job.folder)
    try:
        with wall_clock_limit(ctx.timeout_s, where):
            run = run_one(job.spec, ctx.out, progress, folder,
                          facts={"variation": job.variation})
    except (Exception, SystemExit) as err:  # a crashing controller (or one calling sys.exit)
        return Outcome.failed(job, one_line(failure_text(err)))  # must not end the suite
    if job.repeat != 0:
        return Outcome(job, None, None, run, time.perf_counter() - start)
    result = evaluate(folder, ctx.baselines, ctx.project)
    if result.plots is not None and ctx.draw is not None:
        result = replace(result, static_figures=ctx.draw(result.plots))
    if ctx.strict:
        result = require_baselines(result, ctx.out, ctx.baselines)
    return Outcome(job, result.error, result, run, time.perf_counter() - start)
