"""`kartci baseline update` and `kartci baseline tolerances`: parse, call `kartci.app.accept`
(the only code that writes a baseline's values) or `kartci.app.tolerances` (its tolerances),
print what they did."""

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

    from kartci import project  # with accept's, for this command only

    accepted = accept(out, project.current(), names or (), baselines=baselines,
                      replicas=replicas, jobs=jobs, say=say)
    for one in accepted:
        for line in one.lines():
            out_console.print(line, highlight=False, markup=False)
        for warning in one.warnings:
            say(f"kartci: warning: {one.label}: {warning}")


@baseline_app.command("tolerances")
def baseline_tolerances(
    faults: Annotated[Path, typer.Argument(help="A folder written by `kartci faults`.")],
    baselines: BaselinesOpt = None,
    write: Annotated[bool, typer.Option(
        "--write", help="Store the proposed tolerances in the baseline files.")] = False,
) -> None:
    """Propose each metric's tolerance from a `kartci faults` run: at least 3x its conditioning
    spread (an ill-conditioned one is widened to that), and half the smallest change of a fault
    it lets pass but can see beyond that floor (tightened); otherwise kept. Prints every change
    with the faults behind it, the detection matrix's score at today's and the proposed
    tolerances, and the faults no scenario catches even then; --write stores them."""
    # CLI start-up: the judging behind the proposals loads the runner (+0.5 s)
    from kartci import project
    from kartci.app.tolerances import propose
    from kartci.app.tolerances import write as store

    target = baselines or project.current().baselines
    result = propose(faults, target)
    for p in result.changed():
        moved = ", ".join(f"{f} {m:+.4g}" for f, m in p.moved_by[:3]) or "no fault moves it"
        out_console.print(f"{p.scenario}: {p.metric}: {p.tolerance:.4g} -> {p.proposed:.4g} "
                          f"{p.unit} ({p.why.value}; floor {p.floor:.4g}; {moved})",
                          highlight=False, markup=False)
    now, judged = result.score(proposed=False)
    then, _ = result.score(proposed=True)
    out_console.print(f"detection: {now}/{judged} faults caught at today's tolerances, "
                      f"{then}/{judged} at the proposed ones ({len(result.changed())} changed)",
                      highlight=False, markup=False)
    if unseen := result.unseen():
        out_console.print(f"caught by no scenario even then: {', '.join(unseen)}",
                          highlight=False, markup=False)
    if write:
        for path in store(result, target):
            err_console.print(f"wrote {path}", highlight=False, markup=False)
