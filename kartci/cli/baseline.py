"""`kartci baseline update`: the only command that writes baselines."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.cli.common import BaselinesOpt, baseline_app, baselines_dir, out_console
from kartci.errors import SpecError
from kartci.report.tables import num


@baseline_app.command("update")
def baseline_update(
    out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
    names: Annotated[list[str] | None, typer.Argument(help="Scenarios (default: all in OUT).")]
    = None,
    baselines: BaselinesOpt = None,
) -> None:
    """Store a run's metrics as the baselines; the only command that writes baselines."""
    from kartci.runner import ERROR_NAME
    from kartci.verdict import load, read_metrics, update

    folders = [out / n for n in names] if names else sorted(
        p.parent for p in out.glob("*/metrics.json"))
    if not folders:
        raise SpecError(f"{out}: no <scenario>/metrics.json found; run `kartci run` first")
    target = baselines_dir(baselines, must_exist=False)
    checked = []
    for folder in folders:  # check everything before writing anything
        if (folder / ERROR_NAME).exists():
            raise SpecError(f"{folder}: the last run of this scenario failed; its metrics are "
                            "stale and will not become a baseline")
        load(target / f"{folder.name}.json")
        checked.append((folder, read_metrics(folder / "metrics.json")))
    for folder, values in checked:
        changes = update(target / f"{folder.name}.json", folder.name, values)
        moved = [c for c in changes if c.kind != "unchanged"]
        out_console.print(f"{folder.name}: {len(moved)} of {len(changes)} metrics changed",
                          highlight=False)
        for c in moved:
            out_console.print(f"  {c.kind:8s} {c.metric}: {num(c.old)} -> {num(c.new)}",
                              highlight=False)
