"""`kartci search`: look for the run that breaks a scenario and shrink it toward its own values."""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Annotated

import typer
from rich.text import Text

from kartci import project
from kartci.cli.common import (
    AllowOutsideOpt,
    BaselinesOpt,
    OutOpt,
    SetOpt,
    app,
    baselines_dir,
    complete_scenario,
    err_console,
    out_console,
    out_dir,
)
from kartci.errors import SpecError
from kartci.runner.kinds import ExecutorKind

if TYPE_CHECKING:
    from kartci.runner.search import Snapshot


@contextmanager
def _progress(live: bool) -> Iterator[Callable[[Snapshot], None]]:
    """A status line on a terminal (runs so far, the smallest margin and where); nothing in CI
    or a pipe, where the summary at the end says it all."""
    if not live:
        yield lambda snap: None
        return
    with err_console.status("search: starting") as status:
        def show(snap: Snapshot) -> None:
            best = snap.best
            where = "" if best is None else (
                f"; smallest margin {best.margin:.3g} at "
                + ", ".join(f"{k}={v}" for k, v in best.point)) if best.value is None else (
                f"; worst {best.value:.4g} at " + ", ".join(f"{k}={v}" for k, v in best.point))
            status.update(Text(f"search ({snap.phase.value}): {snap.runs} of {snap.budget} "
                               f"runs{where}"))
        yield show


@app.command()
def search(
    name: Annotated[str, typer.Argument(help="Scenario name or YAML path.",
                                        autocompletion=complete_scenario)],
    over: Annotated[list[str], typer.Option(
        help="KEY=LOW..HIGH, KEY=LOW..HIGH:STEP or KEY=a,b,c: an axis of the space searched "
             "(repeatable). A range the key takes only on a grid (a period in whole physics "
             "steps) gets the grid's step.")],
    set_: SetOpt = None,
    budget: Annotated[int, typer.Option(
        help="Runs at most, search and shrinking together (at most 10,000).")] = 100,
    objective: Annotated[str, typer.Option(
        help="criteria: find a run failing the scenario's criteria, shrunk toward the "
             "scenario's own values; or a METRIC name: find the run where it is worst.")
    ] = "criteria",
    seed: Annotated[int, typer.Option(help="Seed of the sampler: the same seed gives the same "
                                           "search, at any -j.")] = 0,
    jobs: Annotated[int, typer.Option(
        "--jobs", "-j", help="Runs at once (as kartci run -j).")] = 1,
    executor: Annotated[ExecutorKind, typer.Option(
        help="local: this process, or a process pool with -j N; ray: Ray tasks.")
    ] = ExecutorKind.LOCAL,
    ray_address: Annotated[str | None, typer.Option(
        help="Ray cluster to use (default: start a local Ray instance).")] = None,
    timeout_s: Annotated[float | None, typer.Option(
        "--timeout-s", help="Wall-clock limit per run, s: a slower run is an error.")] = None,
    out: OutOpt = None,
    baselines: BaselinesOpt = None,
    allow_outside_paths: AllowOutsideOpt = False,
) -> None:
    """Search a scenario's space for a run that fails its criteria, then shrink it toward the
    scenario's own values (the nearest failure, its boundary bracketed on each axis).

    Writes OUT/found.yaml (the failure as a scenario file: `kartci run OUT/found.yaml`),
    OUT/search.html (the explored space and the boundary), OUT/search.json (the journal: the
    same command with the same --out resumes an interrupted search) and each run's folder.
    Exit 1 when a failure was found, 0 when none was, 2 on bad input.
    """
    from kartci.app.search import FOUND, Options, Request, run_search  # the runner: +0.9 s

    if jobs < 1:
        raise SpecError(f"--jobs {jobs}: expected 1 or more")
    if timeout_s is not None and not timeout_s > 0:
        raise SpecError(f"--timeout-s {timeout_s:g}: expected a positive number of seconds")
    if ray_address and executor is not ExecutorKind.RAY:
        raise SpecError("--ray-address needs --executor ray")
    target = out_dir(out, "search")
    request = Request(name, tuple(over), tuple(set_ or ()), budget, objective, seed,
                      allow_outside_paths)
    opts = Options(baselines_dir(baselines), project.current(), jobs, executor, ray_address,
                   timeout_s)
    live = err_console.is_terminal and not os.environ.get("CI")
    with _progress(live) as progress:
        result = run_search(request, target, opts, progress)
    found = result.found
    runs = len(found.counted)
    replayed = f" ({result.resumed} replayed from {target / 'search.json'})" \
        if result.resumed else ""
    e = found.failure
    if objective == "criteria" and e is not None and e.status.failing:
        values = ", ".join(f"{k}={v}" for k, v in e.point)
        out_console.print(Text(f"{name}: FAILED at {values}: {'; '.join(e.why)}"),
                          highlight=False)
        for b in found.brackets:
            out_console.print(Text(f"  boundary of {b.key}: {b.passing} passes, {b.failing} "
                                   "fails"), highlight=False)
        how = ("the failure nearest the scenario's own values found" if found.shrunk else
               "the budget ran out while shrinking: a failure nearer the scenario's own values "
               "may exist (a larger --budget resumes it)")
        out_console.print(Text(f"  {runs} of {budget} runs{replayed}; {how}"), highlight=False)
    elif e is not None and objective != "criteria":
        values = ", ".join(f"{k}={v}" for k, v in e.point)
        failing = sum(1 for r in found.counted if r.status.failing)
        out_console.print(Text(f"{name}: worst {objective} {e.value:.4g} at {values} "
                               f"({runs} of {budget} runs{replayed}; {failing} failed their "
                               "criteria)"), highlight=False)
    else:
        small = found.smallest
        where = "" if small is None else f" at {', '.join(f'{k}={v}' for k, v in small.point)}"
        margin = "none" if small is None else f"{small.margin:.3g}"
        out_console.print(Text(f"{name}: no failure in {runs} runs{replayed}; covered "
                               f"{found.coverage:.0%} of the space ({found.covered} of "
                               f"{found.cells} cells); smallest margin {margin}{where}"),
                          highlight=False)
    if result.found_yaml is not None:
        out_console.print(Text(f"found: {target / FOUND}  (run it: kartci run "
                               f"{target / FOUND})"), highlight=False)
    code = result.exit_code
    out_console.print(Text(f"report: {result.page}  (exit {code})"), highlight=False)
    raise typer.Exit(code)
