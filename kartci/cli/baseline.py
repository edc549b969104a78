"""`kartci baseline update`: the only command that writes baselines."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.cli.common import BaselinesOpt, baseline_app, baselines_dir, out_console
from kartci.errors import SpecError


def exact(x: float | None) -> str:
    """A value as the shortest text that reads back as the same float: a change shows even
    where 4 significant digits would print "0.6612 -> 0.6612"."""
    return "—" if x is None else repr(float(x))


@baseline_app.command("update")
def baseline_update(
    out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
    names: Annotated[list[str] | None, typer.Argument(
        help="Scenarios (default: those of the last run in OUT).")] = None,
    baselines: BaselinesOpt = None,
) -> None:
    """Store a run's metrics as the baselines, and a decimated reference trace of its paths
    (baselines/traces/, for the report's overlay); the only command that writes baselines. Only a
    complete, current run is taken: a scenario whose last run failed or did not finish is
    refused, and with no names only the scenarios of the last run in OUT are taken."""
    from kartci.runner.outdir import locked, read_manifest, valid_label
    from kartci.runner.run import check_complete, reference_plots
    from kartci.verdict import load, read_metrics, update
    from kartci.verdict.trace import trace_path, write_trace

    if not out.is_dir():
        raise SpecError(f"{out}: no such folder; run `kartci run` first")
    target = baselines_dir(baselines, must_exist=False)
    with locked(out):
        labels = names or read_manifest(out)
        bad = [n for n in labels if not valid_label(n)]
        if bad:
            raise SpecError(f"{bad[0]}: not a scenario name (a folder directly in {out})")
        if not labels:
            raise SpecError(f"{out}: its last run had no scenarios")
        checked = []
        for label in labels:  # check everything before writing anything
            folder = out / label
            check_complete(folder)
            load(target / f"{label}.json")
            checked.append((label, read_metrics(folder / "metrics.json")))
        # the traces' plots read the logs: after the cheap checks, still before any write
        traced = [(label, values, reference_plots(out / label)) for label, values in checked]
        for label, values, drawn in traced:
            changes = update(target / f"{label}.json", label, values)
            moved = [c for c in changes if c.kind != "unchanged"]
            out_console.print(f"{label}: {len(moved)} of {len(changes)} metrics changed",
                              highlight=False, markup=False)
            for c in moved:
                out_console.print(f"  {c.kind:8s} {c.metric}: {exact(c.old)} -> {exact(c.new)}",
                                  highlight=False, markup=False)
            if drawn is not None and drawn.tracks:
                size = write_trace(trace_path(target, label), drawn)
                out_console.print(f"  reference trace {trace_path(target, label)} ({size} bytes)",
                                  highlight=False, markup=False)
