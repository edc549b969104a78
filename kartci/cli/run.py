"""`kartci run`: run, record, score and judge scenarios."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Annotated

import typer
from rich.progress import Progress

from kartci import project
from kartci.cli.common import (
    AllowOutsideOpt,
    BaselinesOpt,
    OutOpt,
    SetOpt,
    StrictOpt,
    app,
    baselines_dir,
    complete_scenario,
    err_console,
    finish,
    out_dir,
    strict_mode,
)
from kartci.core import broken
from kartci.errors import PluginError, SpecError
from kartci.runner.gate import judging_all
from kartci.runner.kinds import ExecutorKind
from kartci.runner.outdir import check_inside, clear_reports, locked, write_manifest

SWEEP_LINE_EVERY = 1000  # points: a line per this many in a CI log


@contextmanager
def live_server(on: bool, port: int, rate: float) -> Iterator[None]:
    """The --live server around the runs, when asked for."""
    if not on:
        yield
        return
    from kartci.live import serving  # CLI start-up: the log writer (+0.3 s), for --live only

    with serving(port, rate) as view:
        err_console.print(f"live: ws://127.0.0.1:{view.port} (Foxglove: Open connection, "
                          "Foxglove WebSocket)", highlight=False, markup=False)
        yield


@contextmanager
def validating(live: bool) -> Iterator[Callable[[int, int], None]]:
    """Progress of validating a sweep's points (a large grid takes a while): a bar on a
    terminal, otherwise a line every SWEEP_LINE_EVERY points (a small run prints nothing)."""
    if not live:
        def line(done: int, total: int) -> None:
            if done % SWEEP_LINE_EVERY == 0:
                err_console.print(f"validated {done:,} of {total:,} sweep points",
                                  highlight=False)
        yield line
        return
    with Progress(console=err_console, transient=True) as bar:
        task = bar.add_task("validating sweep points", total=None)
        yield lambda done, total: bar.update(task, completed=done, total=total)


@app.command()
def run(
    names: Annotated[list[str] | None, typer.Argument(
        help="Scenario names or YAML paths (default: every scenario in scenarios/).",
        autocompletion=complete_scenario)] = None,
    set_: SetOpt = None,
    out: OutOpt = None,
    baselines: BaselinesOpt = None,
    jobs: Annotated[int | None, typer.Option(
        "--jobs", "-j", help="Runs at once: this process and N-1 worker processes (local), "
                             "or Ray CPUs [default: 1 local, all cores on Ray].")] = None,
    shard: Annotated[str | None, typer.Option(
        help="I/N: run share I of N (labels sorted, dealt round-robin); OUT holds a partial "
             "result for `kartci merge`.")] = None,
    executor: Annotated[ExecutorKind, typer.Option(
        help="local: this process, or a process pool with -j N; ray: one Ray task per run "
             '(pip install "kartci[ray]").')] = ExecutorKind.LOCAL,
    ray_address: Annotated[str | None, typer.Option(
        help="Ray cluster to use (default: start a local Ray instance).")] = None,
    sweep: Annotated[list[str] | None, typer.Option(
        help="key=v1,v2,...: one run per value, into OUT/<scenario>@<key>=<value> "
             "(repeatable: every combination).")] = None,
    repeat: Annotated[int, typer.Option(
        help="Run K seeds (seed, seed+1, ...): extra runs in OUT/<scenario>/repeat_<k>/, for "
             "`kartci compare`.")] = 1,
    conditioning: Annotated[int, typer.Option(
        help="Check how well-conditioned each metric is: K replicas (the run itself and K-1 "
             "with every robot's start moved k nm sideways) in OUT/<scenario>/repeat_<k>/; "
             "each metric's spread over them is judged against its tolerance and a metric "
             "whose spread exceeds it is flagged ill-conditioned. 0: off.")] = 0,
    timeout_s: Annotated[float | None, typer.Option(
        "--timeout-s", help="Wall-clock limit per run, s: a slower run is an error (held "
                            "within a second, even inside a slow controller step).")] = None,
    strict: StrictOpt = None,
    live_view: Annotated[bool, typer.Option(
        "--live", help="Serve each run to Foxglove as it runs (WebSocket on 127.0.0.1, paced "
                       "to real time; one run at a time).")] = False,
    live_port: Annotated[int, typer.Option(
        help="Port of the --live server (0: any free port).")] = 8765,
    live_rate: Annotated[float, typer.Option(
        help="--live pace: sim seconds per wall second (0: as fast as it runs).")] = 1.0,
    allow_outside_paths: AllowOutsideOpt = False,
) -> None:
    """Run scenarios, record each as OUT/<scenario>/run.mcap, score and judge them.

    Exit 0 when everything passes, 1 on a regression or failed criterion, 2 on bad input or a
    run error. Reports: OUT/report.html, summary.md, summary.json, junit.xml.
    """
    # CLI start-up: the runner, the simulator and the report's figures (+0.9 s)
    from kartci.report.progress import ProgressView
    from kartci.report.static import scenario_svgs
    from kartci.runner import (
        expand,
        parse_shard,
        refused_results,
        run_jobs,
        runnable,
        shard_labels,
    )
    from kartci.runner.jobs import Vary, check_count, default_suite
    from kartci.runner.merge import write_marker

    out = out_dir(out, "latest")
    if jobs is not None and jobs < 1:
        raise SpecError(f"--jobs {jobs}: expected 1 or more")
    for option, count in (("--jobs", jobs or 1), ("--repeat", repeat),
                          ("--conditioning", conditioning)):
        check_count(option, count)
    if timeout_s is not None and not timeout_s > 0:
        raise SpecError(f"--timeout-s {timeout_s:g}: expected a positive number of seconds")
    if ray_address and executor is not ExecutorKind.RAY:
        raise SpecError("--ray-address needs --executor ray")
    part = parse_shard(shard) if shard else None
    if live_view and ((jobs or 1) > 1 or executor is not ExecutorKind.LOCAL):
        raise SpecError("--live serves one run at a time in this process: drop -j / --executor")
    proj = project.current()
    selected = names or default_suite(proj.own_scenarios(), allow_outside_paths)
    if not selected:
        where = ", ".join(str(p) for p in proj.scenarios)
        raise SpecError(f"no scenarios to run: none in {where}; name one (`kartci list` shows "
                        "the built-in ones) or create a project with `kartci init`")
    if conditioning and repeat > 1:
        raise SpecError("--conditioning and --repeat both set the replicas: choose one")
    if conditioning == 1 or conditioning < 0:
        raise SpecError(f"--conditioning {conditioning}: expected 0 (off) or 2 or more")
    live = err_console.is_terminal and not os.environ.get("CI")
    replicas, vary = (conditioning, Vary.START) if conditioning else (repeat, Vary.SEED)
    strict_on = strict_mode(strict)
    check_plugins(strict_on)
    selected, refused = runnable(selected, set_ or [], allow_outside_paths=allow_outside_paths)
    with validating(live) as progress:
        todo = expand(selected, set_ or [], sweep, replicas, vary, progress,
                      allow_outside_paths=allow_outside_paths) if selected else []
    if part is not None:
        mine = shard_labels({j.label for j in todo} | {r.label for r in refused}, *part)
        todo = [j for j in todo if j.label in mine]
        refused = [r for r in refused if r.label in mine]
    index, total = part or (None, None)
    labels = [*(r.label for r in refused), *(j.label for j in todo if j.repeat == 0)]
    workers = jobs or (os.cpu_count() or 1 if executor is ExecutorKind.RAY else 1)
    with locked(out):  # an unusable or busy --out fails here, before any run
        check_inside(out, labels)
        clear_reports(out)
        write_marker(out, index, total, labels)
        write_manifest(out, "run", labels)
        with judging_all(labels, strict_on) as complete:
            with live_server(live_view, live_port, live_rate), \
                    ProgressView(todo, err_console, live) as view:
                results = run_jobs(todo, out, baselines_dir(baselines), workers=workers,
                                   executor=executor, ray_address=ray_address,
                                   timeout_s=timeout_s, strict=strict_on, on_event=view,
                                   draw=scenario_svgs)
            results = complete([*refused_results(refused, out), *results])
        finish(results, out, ci=part is None)


def check_plugins(strict: bool) -> None:
    """Plugins that failed to load: in strict mode (CI) a PluginError naming them all (exit 2,
    before anything runs or is written: a team's broken configuration must not pass because
    its scenarios happen not to name the plugin); otherwise a warning for each, once, and
    only the scenarios that name one fail."""
    failed = broken()
    if strict and failed:
        raise PluginError(f"{'; '.join(p.message for p in failed)} (strict mode, as under CI: "
                          "a plugin that fails to load fails the run; fix or uninstall it, or "
                          "pass --no-strict to run the scenarios that do not need it)",
                          failed[0].trace)
    for plugin in failed:
        err_console.print(f"kartci: warning: {plugin.message}; the scenarios that name it fail "
                          "(its traceback: traceback.txt in their folders)", highlight=False,
                          markup=False, soft_wrap=True)
