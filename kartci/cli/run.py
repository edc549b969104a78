"""`kartci run`: run, record, score and judge scenarios."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Annotated

import typer
from rich.progress import Progress

from kartci import project
from kartci.app.suite import SuiteRequest, SuiteView, run_suite
from kartci.cli.common import (
    AllowOutsideOpt,
    BaselinesOpt,
    OutOpt,
    SetOpt,
    StrictOpt,
    app,
    complete_scenario,
    conclude,
    err_console,
    out_dir,
    strict_mode,
)
from kartci.runner.kinds import ExecutorKind

if TYPE_CHECKING:
    from kartci.runner.events import Listener
    from kartci.runner.jobs import Job

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
    from kartci.runner.jobs import parse_shard  # CLI start-up: the simulator (+0.9 s)

    out = out_dir(out, "latest")
    live = err_console.is_terminal and not os.environ.get("CI")
    request = SuiteRequest(
        out, names=tuple(names or ()), overrides=tuple(set_ or ()), baselines=baselines,
        jobs=jobs, shard=parse_shard(shard) if shard else None, executor=executor,
        ray_address=ray_address, sweep=tuple(sweep or ()), repeat=repeat,
        conditioning=conditioning, timeout_s=timeout_s, strict=strict_mode(strict),
        live=live_view, allow_outside_paths=allow_outside_paths)
    view = SuiteView(warn, lambda: validating(live),
                     lambda todo: running(todo, live, live_view, live_port, live_rate))
    suite = run_suite(request, project.current(), view)
    conclude(suite.results, suite.reports, ci=suite.shard is None)


@contextmanager
def running(todo: list[Job], live: bool, live_view: bool, port: int,
            rate: float) -> Iterator[Listener]:
    """The runs' progress (a live table on a terminal, a line per job in CI logs), inside the
    --live server when asked for."""
    from kartci.report.progress import ProgressView  # CLI start-up: rich's live table

    with live_server(live_view, port, rate), ProgressView(todo, err_console, live) as view:
        yield view


def warn(text: str) -> None:
    """A warning on stderr, as every command prints one."""
    err_console.print(f"kartci: warning: {text}", highlight=False, markup=False, soft_wrap=True)


