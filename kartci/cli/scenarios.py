"""`kartci list`, `show` and `schema`: what scenarios there are and what they resolve to."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from kartci.cli.common import SetOpt, app, out_console


@app.command("list")
def list_cmd() -> None:
    """List the scenarios with a one-line description."""
    from kartci.spec import load_scenario, scenario_names

    table = Table("scenario", "description", box=None)
    for name in scenario_names():
        table.add_row(name, load_scenario(name).description)
    out_console.print(table)


@app.command()
def show(name: str, set_: SetOpt = None) -> None:
    """Print a scenario fully resolved (world and model files included, overrides applied)."""
    from kartci.spec import load_scenario

    spec = load_scenario(name, set_ or [])
    typer.echo(json.dumps(spec.model_dump(mode="json"), indent=2))


@app.command()
def schema(out: Annotated[Path | None, typer.Option(help="Write to this file.")] = None) -> None:
    """JSON Schema of scenario files, for editor completion and validation."""
    from kartci.spec import json_schema

    text = json.dumps(json_schema(), indent=2)
    if out is None:
        typer.echo(text)
    else:
        out.write_text(text + "\n", encoding="utf-8")
