"""`kartci merge`, `compare` and `report`: judge and report runs that already exist."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci import project
from kartci.app.suite import compare_suites, merge_shards, rescore_suite
from kartci.cli.common import BaselinesOpt, OutOpt, StrictOpt, app, conclude, out_dir, strict_mode
from kartci.errors import SpecError
from kartci.report import COMPARE


@app.command()
def merge(
    dirs: Annotated[list[Path], typer.Argument(help="Partial results (`run --shard` OUTs).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")],
    baselines: BaselinesOpt = None,
    strict: StrictOpt = None,
    history: Annotated[Path | None, typer.Option(
        help="Folder of earlier commits' summary.json (oldest first by name, as on the "
             "kartci-history branch): report.html plots each metric across them and this run; "
             "a missing folder draws no history.")] = None,
) -> None:
    """Join partial results into one run: copy the scenario folders into OUT, then judge and
    report them exactly as an unsharded run would (same summary, verdicts, exit code). Shards
    of `kartci faults --shard` give one detection matrix, judged with today's baselines."""
    # CLI start-up: the faults workflow and its matrix, for this command only
    from kartci.app.faults import is_faults_folder, merge_faults
    from kartci.cli.faults import conclude_faults

    kinds = {is_faults_folder(d) for d in dirs}
    if kinds == {True}:
        conclude_faults(merge_faults(dirs, out, baselines or project.current().baselines,
                                     project.current()), None)
    if len(kinds) > 1:
        raise SpecError("the folders mix `kartci faults` and `kartci run` results; merge "
                        "each kind on its own")
    suite = merge_shards(dirs, out, baselines, project.current(), strict=strict_mode(strict),
                         history=history)
    conclude(suite.results, suite.reports)


@app.command("compare")
def compare_cmd(
    base: Annotated[Path, typer.Argument(help="The base run's OUT (e.g. the target branch).")],
    head: Annotated[Path, typer.Argument(help="The head run's OUT (e.g. the pull request).")],
    out: OutOpt = None,
    baselines: BaselinesOpt = None,
    alpha: Annotated[float, typer.Option(
        help="Significance level across --repeat samples (Mann-Whitney U).")] = 0.05,
) -> None:
    """Compare head with base, scenario by scenario and metric by metric: base, head, delta,
    verdict (tolerances and directions as for baselines; with repeats, a change must also be
    significant). Reports both runs' paths and time series overlaid. Exit 1 when head
    regressed, 0 when not, 2 when a run failed."""
    out = out_dir(out, "compare")
    suite = compare_suites(base, head, out, baselines, project.current(), alpha=alpha)
    conclude(suite.results, suite.reports, COMPARE)


@app.command()
def report(out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
           baselines: BaselinesOpt = None, strict: StrictOpt = None) -> None:
    """Rebuild metrics and all reports of a run folder from its logs alone (the scenarios of
    its last run); a scenario whose log is missing or damaged is an error."""
    suite = rescore_suite(out, baselines, project.current(), strict=strict_mode(strict))
    conclude(suite.results, suite.reports)



@app.command()
def history(
    summaries: Annotated[list[Path], typer.Argument(
        help="summary.json files of successive commits, oldest first (CI keeps them on the "
             "kartci-history branch).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder for history.html.")] = Path(),
) -> None:
    """Every metric of every scenario across commits (asv-style), as OUT/history.html."""
    from kartci.report.history import write_history  # CLI start-up: pandas (+0.25 s)

    path = write_history(list(summaries), out)
    typer.echo(f"history: {path} ({len(summaries)} commits)")

