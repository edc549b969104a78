"""`kartci baseline update`: parse, call `kartci.app.accept` (the only code that writes
baselines), print what it did."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.cli.common import (
    BaselinesOpt,
    baseline_app,
    err_console,
    out_console,
)


@baseline_app.command("update")
def baseline_update(
    out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
    names: Annotated[list[str] | None, typer.Argument(
        help="Scenarios (default: those of the last run in OUT).")] = None,
    baselines: BaselinesOpt = None,
    replicas: Annotated[int, typer.Option(
        help="Conditioning replicas per scenario: the run itself and K-1 with every robot's "
             "start moved k nm sideways (those missing in OUT are run now); each metric's "
             "spread over them goes into the baseline. 0: record no spread.")] = 4,
    jobs: Annotated[int, typer.Option("--jobs", "-j", help="Replicas run at once.")] = 1,
) -> None:
    """Store a run's metrics as the baselines, with each metric's spread over conditioning
    replicas, where they were made, and a decimated reference trace of its paths
    (baselines/traces/, for the report's overlay); the only command that writes baselines. Only a
    complete, current, pinned run is taken: a scenario whose last run failed or did not finish
    is refused, and with no names only the scenarios of the last run in OUT are taken. A metric
    whose spread exceeds its tolerance is flagged ill-conditioned."""
    from kartci.app.accept import accept  # CLI start-up: the runner loads PyBullet (+0.5 s)

    def say(line: str) -> None:
        err_console.print(line, highlight=False, markup=False)

    accepted = accept(out, names or (), baselines=baselines,
                      replicas=replicas, jobs=jobs, say=say)
    for one in accepted:
        for line in one.lines():
            out_console.print(line, highlight=False, markup=False)
        for warning in one.warnings:
            say(f"kartci: warning: {one.label}: {warning}")
