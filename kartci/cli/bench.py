"""`kartci bench compare`: two benchmark result files side by side, as ratios."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.bench import Change, compare, load
from kartci.cli.common import app

bench_app = typer.Typer(help="Read the JSON files the benchmarks/ scripts write (--json).",
                        no_args_is_help=True, rich_markup_mode=None)
app.add_typer(bench_app, name="bench")


def _num(x: float | None) -> str:
    return "-" if x is None else f"{x:.4g}"


@bench_app.command("compare")
def bench_compare(
    old: Annotated[Path, typer.Argument(help="The earlier benchmark JSON (e.g. from main).")],
    new: Annotated[Path, typer.Argument(help="The later benchmark JSON (e.g. from a branch).")],
    noise: Annotated[float, typer.Option(help="Changes within this fraction count as the "
                                              "same (0.10: 10 %).")] = 0.10,
    fail_worse: Annotated[bool, typer.Option("--fail-worse", help="Exit 1 when any figure got "
                                             "worse by more than --noise.")] = False,
) -> None:
    """Each figure's median in OLD and NEW, their ratio (new / old) and whether it got better
    or worse beyond the noise. Medians from one machine are noisy: trust ratios over many
    figures, not one."""
    rows = compare(load(old), load(new), noise)
    typer.echo(f"{'figure':44s} {'unit':8s} {'old':>10s} {'new':>10s} {'new/old':>8s}  change")
    for r in rows:
        ratio = "-" if r.ratio is None else f"{r.ratio:.2f}x"
        typer.echo(f"{r.name:44s} {r.unit:8s} {_num(r.old):>10s} {_num(r.new):>10s} "
                   f"{ratio:>8s}  {r.change.value}")
    worse = [r.name for r in rows if r.change is Change.WORSE]
    if worse:
        typer.echo(f"worse beyond {noise:.0%}: {', '.join(worse)}")
    if fail_worse and worse:
        raise typer.Exit(1)
