"""`kartci merge`, `compare` and `report`: judge and report runs that already exist."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.cli.common import BaselinesOpt, OutOpt, app, baselines_dir, finish, out_dir
from kartci.errors import SpecError


@app.command()
def merge(
    dirs: Annotated[list[Path], typer.Argument(help="Partial results (`run --shard` OUTs).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")],
    baselines: BaselinesOpt = None,
) -> None:
    """Join partial results into one run: copy the scenario folders into OUT, then judge and
    report them exactly as an unsharded run would (same summary, verdicts, exit code)."""
    from kartci.runner.merge import merge as join

    finish(join(dirs, out, baselines_dir(baselines)), out)


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
    from kartci.report import COMPARE
    from kartci.runner.compare import compare_outs

    out = out_dir(out, "compare")
    if not 0 < alpha < 1:
        raise SpecError(f"--alpha {alpha:g}: expected 0 < alpha < 1")
    finish(compare_outs(base, head, baselines_dir(baselines), alpha), out, COMPARE)


@app.command()
def report(out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
           baselines: BaselinesOpt = None) -> None:
    """Rebuild metrics and all reports of a run folder from its logs alone."""
    from kartci.runner import rescore

    finish(rescore(out, baselines_dir(baselines)), out)
