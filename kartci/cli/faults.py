"""`kartci faults`: inject a catalogue of faults into scenarios and show which the gate catches."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, NoReturn

import typer
from rich.box import SIMPLE_HEAD
from rich.table import Column, Table
from rich.text import Text

from kartci import project
from kartci.cli.common import (
    AllowOutsideOpt,
    BaselinesOpt,
    OutOpt,
    app,
    complete_scenario,
    err_console,
    out_console,
    out_dir,
)
from kartci.errors import SpecError
from kartci.runner.kinds import ExecutorKind

if TYPE_CHECKING:
    from kartci.app.faults import FaultsResult, Matrix
    from kartci.runner.events import Listener
    from kartci.runner.jobs import Job

# a cell of the terminal matrix: one mark, as on the page's heat map, so that 14 scenarios
# and full fault names fit in 100 columns; the legend names them
_CELL = {"caught": ("✓", "green"), "missed": ("✗", "bold red"), "no effect": ("=", "yellow"),
         "not applicable": ("·", "dim"), "error": ("!", "magenta")}


@contextmanager
def _running(todo: list[Job], live: bool) -> Iterator[Listener]:
    from kartci.report.progress import ProgressView  # CLI start-up: rich's live table

    with ProgressView(todo, err_console, live) as view:
        yield view


def print_matrix(matrix: Matrix) -> None:
    """Faults (rows) x scenarios (numbered columns, named below) on the terminal, each fault's
    score in the margin, each scenario's under the table, then each caught cell's metrics and
    each missed cell's nearest metric."""
    table = Table(Column("fault", no_wrap=True),
                  *(Column(str(i), justify="center") for i, _ in enumerate(matrix.scenarios, 1)),
                  Column("caught", no_wrap=True), title=Text("detection matrix"),
                  title_justify="left", box=SIMPLE_HEAD, pad_edge=False)
    for e in matrix.faults:
        row = []
        for s in matrix.scenarios:
            word, style = _CELL[matrix.cell(e.name, s).cell.value]
            row.append(Text(word, style=style))
        table.add_row(Text(e.name), *row, matrix.fault_score(e.name).text() or "-")
    out_console.print(table)
    out_console.print(Text("  ".join(f"{mark} {word}" for word, (mark, _) in _CELL.items())),
                      highlight=False)
    for i, s in enumerate(matrix.scenarios, 1):
        out_console.print(Text(f"{i:>3} {s}: {matrix.scenario_score(s).text() or '-'}"),
                          highlight=False)
    out_console.print(Text(f"suite: {matrix.score.text()}", style="bold"), highlight=False)
    if none := matrix.score.no_effect:
        out_console.print(Text(f"{none} cells with no effect (no metric moved beyond its "
                               "resolution) are not scored"), highlight=False)
    for c in matrix.cells:
        if c.cell.value == "caught":
            out_console.print(Text(f"{c.fault} on {c.scenario}: caught by "
                                   f"{'; '.join(c.caught_by)}"), highlight=False)
        elif c.cell.value in ("missed", "no effect", "error"):
            out_console.print(Text(f"{c.fault} on {c.scenario}: {c.cell.value.upper()}"
                                   + (f": {c.why}" if c.why else "")), highlight=False)


@app.command()
def faults(
    names: Annotated[list[str] | None, typer.Argument(
        help="Scenario names or YAML paths (default: the default suite, as `kartci run`).",
        autocompletion=complete_scenario)] = None,
    catalogue: Annotated[str, typer.Option(
        help="The fault catalogue: the faults robot kinds, controllers, nodes and worlds "
             "declare in it.")] = "standard",
    only: Annotated[list[str] | None, typer.Option(
        help="Only this fault (OWNER.FAULT, e.g. line_pid.kp_x0.7; repeatable).")] = None,
    jobs: Annotated[int, typer.Option(
        "--jobs", "-j", help="Runs at once (as kartci run -j).")] = 1,
    shard: Annotated[str | None, typer.Option(
        help="I/N: only share I of N of the scenarios (each with all its faults); "
             "OUT then holds that share's matrix.")] = None,
    executor: Annotated[ExecutorKind, typer.Option(
        help="local: this process, or a process pool with -j N; ray: Ray tasks.")
    ] = ExecutorKind.LOCAL,
    ray_address: Annotated[str | None, typer.Option(
        help="Ray cluster to use (default: start a local Ray instance).")] = None,
    timeout_s: Annotated[float | None, typer.Option(
        "--timeout-s", help="Wall-clock limit per run, s: a slower run is an error.")] = None,
    min_score: Annotated[float | None, typer.Option(
        help="Exit 1 when the suite catches less than this fraction (0-1) of the faults "
             "judged.")] = None,
    rejudge: Annotated[bool, typer.Option(
        "--rejudge", help="Run nothing: judge OUT's runs again with today's baselines (after "
                          "`kartci baseline tolerances --write`).")] = False,
    out: OutOpt = None,
    baselines: BaselinesOpt = None,
    allow_outside_paths: AllowOutsideOpt = False,
) -> None:
    """Run each scenario as written and under each fault of a catalogue that acts on it, and
    judge every faulted run against the scenario's own run with its baseline's tolerances
    (as `kartci compare` does): caught (a metric fails the gate), missed (a metric moved, all
    within tolerance), no effect (no metric moved beyond its resolution: not scored) or not
    applicable (nothing in the scenario for the fault to act on).

    Writes OUT/<scenario>/ and OUT/<scenario>@fault=<fault>/ (run folders), OUT/summary.json
    (the detection matrix and scores) and OUT/faults.html (the matrix as a heat map).
    Exit 0 when the matrix was computed (1 below --min-score), 2 on bad input.
    """
    # CLI start-up: the runner and the simulator (+0.9 s), for this command only
    from kartci.app.faults import Request, run_faults
    from kartci.app.faults import rejudge as judge_again
    from kartci.runner.jobs import parse_shard

    target = out_dir(out, "faults")
    base = Path(baselines) if baselines is not None else None
    if rejudge:
        if names or only or shard:
            raise SpecError("--rejudge judges the runs already in --out again; give it no "
                            "scenarios, --only or --shard")
        result = judge_again(target, base or project.current().baselines, min_score)
    else:
        live = err_console.is_terminal and not os.environ.get("CI")
        request = Request(target, tuple(names or ()), catalogue, tuple(only or ()), base, jobs,
                          parse_shard(shard) if shard else None, executor, ray_address,
                          timeout_s, min_score, allow_outside_paths)
        result = run_faults(request, project.current(), lambda todo: _running(todo, live))
    conclude_faults(result, min_score)


def conclude_faults(result: FaultsResult, min_score: float | None) -> NoReturn:
    """Print the matrix and where it is written, and exit with the result's code."""
    print_matrix(result.matrix)
    code = result.exit_code
    if code and min_score is not None:
        out_console.print(Text(f"score {result.matrix.score.text()} is below --min-score "
                               f"{min_score:g}"), highlight=False)
    out_console.print(Text(f"matrix: {result.summary}  report: {result.page}  (exit {code})"),
                      highlight=False)
    raise typer.Exit(code)
