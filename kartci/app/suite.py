"""A suite of runs into one output folder: the workflow behind `kartci run`, `merge`, `report`
and `compare`, `kartci.run_suite` and `kartci.merge`, and the pytest plugin's `--kartci-shard`.

Each function checks its options, locks OUT, writes its manifest, runs or judges, and writes
the reports while OUT is still locked; the caller prints and exits (`cli/`) or returns the
`Suite` (`kartci.api`). What a terminal shows while it works (sweep validation, the runs'
progress, warnings) comes in through a `SuiteView`, so the workflow itself prints nothing.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from kartci.core import broken
from kartci.errors import KartciError, PluginError, RunError, SpecError, one_line
from kartci.project import Project
from kartci.report import COMPARE, RUN, Wording, write_all
from kartci.runner.gate import judging_all, require_baselines
from kartci.runner.kinds import ExecutorKind
from kartci.runner.outdir import (
    check_inside,
    clear_reports,
    locked,
    manifest_labels,
    write_manifest,
)
from kartci.verdict.result import ScenarioResult, exit_code

if TYPE_CHECKING:  # the runner's jobs load the simulator, which `kartci --help` does not need
    from kartci.runner.events import Listener
    from kartci.runner.jobs import Job, Progress

Shard = tuple[int, int]  # (I, N): share I of N, 1 <= I <= N


@dataclass(frozen=True)
class SuiteRequest:
    """What to run, as `kartci run`'s options say it. Defaults are the CLI's."""

    out: Path  # the output folder: OUT/<label>/ per scenario, the reports at the top
    names: tuple[str, ...] = ()  # scenario names or YAML paths; () the project's default suite
    overrides: tuple[str, ...] = ()  # `dotted.key=value` (--set)
    baselines: Path | None = None  # folder of baseline files; None: the project's
    jobs: int | None = None  # runs at once; None: 1 locally, every core on Ray
    shard: Shard | None = None  # run only share I of N; OUT is then a partial result
    executor: ExecutorKind = ExecutorKind.LOCAL
    ray_address: str | None = None  # with ExecutorKind.RAY; None: a local Ray instance
    sweep: tuple[str, ...] = ()  # `key=v1,v2,...`: one run per value (every combination)
    repeat: int = 1  # seeds per scenario (seed, seed+1, ...)
    conditioning: int = 0  # start replicas per scenario (0: off, else 2 or more)
    timeout_s: float | None = None  # wall-clock limit per run, s
    strict: bool = False  # a scenario without (or with a stale) baseline fails
    live: bool = False  # served to Foxglove as it runs: one run at a time in this process
    allow_outside_paths: bool = False  # files outside the project and kartci's data


def _no_progress() -> AbstractContextManager[Progress]:
    @contextmanager
    def ignored() -> Iterator[Progress]:
        yield lambda done, total: None
    return ignored()


def _no_events(jobs: list[Job]) -> AbstractContextManager[Listener]:
    @contextmanager
    def ignored() -> Iterator[Listener]:
        yield lambda event: None
    return ignored()


def _to_stderr(text: str) -> None:
    print(f"kartci: warning: {text}", file=sys.stderr)


@dataclass(frozen=True)
class SuiteView:
    """What the caller shows while a suite works; the defaults show nothing but warnings
    (on stderr)."""

    warn: Callable[[str], None] = _to_stderr  # one warning, without the `kartci: warning:`
    # around validating a sweep's points: yields the progress callback (points done, total)
    validating: Callable[[], AbstractContextManager[Progress]] = _no_progress
    # around the runs themselves, given the jobs: yields the listener of their events
    running: Callable[[list[Job]], AbstractContextManager[Listener]] = _no_events


@dataclass(frozen=True)
class Suite:
    """A suite's results as written to OUT, and where its reports are."""

    out: Path
    results: list[ScenarioResult]
    reports: dict[str, Path] = field(default_factory=dict)  # "html", "markdown", "json", ...
    shard: Shard | None = None  # a partial result, for `merge`

    @property
    def exit_code(self) -> int:
        """The exit code the CLI gives (0 all pass, 1 a regression or a failed criterion, 2 a
        run error)."""
        return exit_code(self.results)

    @property
    def passed(self) -> bool:
        """Whether every scenario passed (exit code 0)."""
        return self.exit_code == 0


def check_shard(shard: Shard) -> Shard:
    """A share (I, N) with 1 <= I <= N, else a SpecError."""
    index, total = shard
    if not 1 <= index <= total:
        raise SpecError(f"shard {index}/{total}: expected I/N with 1 <= I <= N, e.g. 1/4")
    return shard


def shard_of(labels: Sequence[str], shard: Shard | None) -> set[str]:
    """The labels share `shard` runs (all of them without one): sorted, dealt round-robin, as
    `kartci run --shard` deals them."""
    from kartci.runner.jobs import shard_labels  # start-up: the simulator, as in run_suite

    return set(labels) if shard is None else shard_labels(set(labels), *check_shard(shard))


def run_suite(request: SuiteRequest, project: Project, view: SuiteView | None = None) -> Suite:
    """Run, record, score and judge the requested scenarios into `request.out` and write its
    reports. Every option is checked before anything runs or is written; bad input is a
    SpecError (a PluginError, in strict mode, for a plugin that failed to load)."""
    # start-up: the runner and the simulator load when a suite runs, not with the CLI
    from kartci.report.static import scenario_svgs
    from kartci.runner import expand, refused_results, run_jobs, runnable
    from kartci.runner.jobs import Vary, check_count, default_suite
    from kartci.runner.merge import write_marker

    r, view = request, view or SuiteView()
    if r.jobs is not None and r.jobs < 1:
        raise SpecError(f"--jobs {r.jobs}: expected 1 or more")
    for option, count in (("--jobs", r.jobs or 1), ("--repeat", r.repeat),
                          ("--conditioning", r.conditioning)):
        check_count(option, count)
    if r.timeout_s is not None and not r.timeout_s > 0:
        raise SpecError(f"--timeout-s {r.timeout_s:g}: expected a positive number of seconds")
    if r.ray_address and r.executor is not ExecutorKind.RAY:
        raise SpecError("--ray-address needs --executor ray")
    part = check_shard(r.shard) if r.shard is not None else None
    if r.live and ((r.jobs or 1) > 1 or r.executor is not ExecutorKind.LOCAL):
        raise SpecError("--live serves one run at a time in this process: drop -j / --executor")
    selected = list(r.names) or default_suite(project.own_scenarios(), project,
                                                r.allow_outside_paths)
    if not selected:
        where = ", ".join(str(p) for p in project.scenarios)
        raise SpecError(f"no scenarios to run: none in {where}; name one (`kartci list` shows "
                        "the built-in ones) or create a project with `kartci init`")
    if r.conditioning and r.repeat > 1:
        raise SpecError("--conditioning and --repeat both set the replicas: choose one")
    if r.conditioning == 1 or r.conditioning < 0:
        raise SpecError(f"--conditioning {r.conditioning}: expected 0 (off) or 2 or more")
    replicas, vary = (r.conditioning, Vary.START) if r.conditioning else (r.repeat, Vary.SEED)
    check_plugins(r.strict, view.warn)
    overrides = list(r.overrides)
    selected, refused = runnable(selected, overrides, project,
                                 allow_outside_paths=r.allow_outside_paths)
    with view.validating() as progress:
        todo = expand(selected, overrides, project, list(r.sweep) or None, replicas, vary,
                      progress,
                      allow_outside_paths=r.allow_outside_paths) if selected else []
    if part is not None:
        mine = shard_of([*(j.label for j in todo), *(x.label for x in refused)], part)
        todo = [j for j in todo if j.label in mine]
        refused = [x for x in refused if x.label in mine]
    index, total = part or (None, None)
    labels = [*(x.label for x in refused), *(j.label for j in todo if j.repeat == 0)]
    workers = r.jobs or (os.cpu_count() or 1 if r.executor is ExecutorKind.RAY else 1)
    out = r.out
    with locked(out):  # an unusable or busy OUT fails here, before any run
        check_inside(out, labels)
        clear_reports(out)
        write_marker(out, index, total, labels)
        write_manifest(out, "run", labels)
        with judging_all(labels, r.strict) as complete:
            with view.running(todo) as on_event:
                results = run_jobs(todo, out, _baselines(r.baselines, project), project,
                                   workers=workers, executor=r.executor,
                                   ray_address=r.ray_address, timeout_s=r.timeout_s,
                                   strict=r.strict, on_event=on_event, draw=scenario_svgs)
            results = complete([*refused_results(refused, out), *results])
        return Suite(out, results, write_reports(results, out), part)


def check_plugins(strict: bool, warn: Callable[[str], None]) -> None:
    """Plugins that failed to load: in strict mode (CI) a PluginError naming them all (before
    anything runs or is written: a team's broken configuration must not pass because its
    scenarios happen not to name the plugin); otherwise a warning for each, once, and only the
    scenarios that name one fail."""
    failed = broken()
    if strict and failed:
        raise PluginError(f"{'; '.join(p.message for p in failed)} (strict mode, as under CI: "
                          "a plugin that fails to load fails the run; fix or uninstall it, or "
                          "pass --no-strict to run the scenarios that do not need it)",
                          failed[0].trace)
    for plugin in failed:
        warn(f"{plugin.message}; the scenarios that name it fail (its traceback: traceback.txt "
             "in their folders)")


def merge_shards(dirs: Sequence[Path], out: Path, baselines: Path | None,
                 project: Project, *, strict: bool = False,
                 history: Path | None = None) -> Suite:
    """Join partial results (each a sharded run's OUT) into one run in `out`: copy the scenario
    folders, then judge and report them exactly as an unsharded run would. `history`: a folder
    of earlier commits' summary.json for report.html. `project` gives the default baselines
    and the tolerance policy."""
    from kartci.runner.merge import merge  # start-up: PyBullet (+0.4 s)

    with locked(out):
        clear_reports(out)
        results = merge(list(dirs), out, _baselines(baselines, project), project, strict)
        write_manifest(out, "merge", [x.name for x in results])
        return Suite(out, results, write_reports(results, out, history=history))


def rescore_suite(out: Path, baselines: Path | None, project: Project, *,
                  strict: bool = False) -> Suite:
    """Rebuild the metrics and reports of a run's OUT from its logs alone (the scenarios of its
    last run); a scenario whose log is missing or damaged is an error."""
    from kartci.runner import rescore  # start-up: PyBullet (+0.5 s)

    if not out.is_dir():
        raise SpecError(f"{out}: no such folder")
    target = _baselines(baselines, project)
    with locked(out):
        clear_reports(out)
        results = rescore(out, target, project)
        if strict:
            results = [require_baselines(x, out, target) for x in results]
        if manifest_labels(out) is None:
            write_manifest(out, "report", [x.name for x in results])
        return Suite(out, results, write_reports(results, out))


def compare_suites(base: Path, head: Path, out: Path, baselines: Path | None,
                   project: Project, *, alpha: float = 0.05) -> Suite:
    """Head's OUT judged against base's, scenario by scenario and metric by metric, reported
    in `out` (with repeats, a change must also be significant at `alpha`)."""
    from kartci.runner.compare import compare_outs  # start-up: PyBullet, scipy (+1 s)

    if not 0 < alpha < 1:
        raise SpecError(f"--alpha {alpha:g}: expected 0 < alpha < 1")
    with locked(out):
        clear_reports(out)
        results = compare_outs(base, head, _baselines(baselines, project), project, alpha)
        return Suite(out, results, write_reports(results, out, COMPARE))


def write_reports(results: list[ScenarioResult], out: Path, words: Wording = RUN,
                  history: Path | None = None, html: bool = True,
                  static: bool = True) -> dict[str, Path]:
    """Every report in `out` (the HTML ones with `html`, report-static.html with `static` too),
    by kind. A report that cannot be
    drawn is a RunError (bad input, not a regression), and no earlier report stays in its
    place (write_all removes them first)."""
    try:
        return write_all(results, out, words, history, html, static)
    except (KartciError, OSError):
        raise
    except Exception as err:
        raise RunError(f"writing the reports in {out} failed: {type(err).__name__}: "
                       f"{one_line(str(err), 200)} (no report was left in place)") from err


def _baselines(given: Path | None, project: Project) -> Path:
    """The baselines folder: `given` (which must exist), else the project's."""
    if given is not None and not given.is_dir():
        raise SpecError(f"--baselines {given}: no such folder")
    return given if given is not None else project.baselines
