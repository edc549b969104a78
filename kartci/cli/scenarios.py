"""`kartci list`, `show`, `schema` and `plugins`: what scenarios there are, what they resolve
to, and what they can name."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table
from rich.text import Text

from kartci import project
from kartci.cli.common import (
    AllowOutsideOpt,
    SetOpt,
    app,
    complete_scenario,
    err_console,
    out_console,
)
from kartci.core import broken, catalogue
from kartci.core.loading import stdout_to_stderr
from kartci.errors import SpecError
from kartci.scenario import load_scenario, scenario_catalogue
from kartci.scenario.schema import scenario_schema, write_schema


@app.command("list")
def list_cmd() -> None:
    """List the scenarios, where each comes from and what it does.

    Every scenario reachable by name: the project's own, then kartci's built-ins, each with its
    one-line description. A file that cannot be loaded is listed with its error (exit 2); the
    others are listed all the same. Exit 1 when a plugin failed to load (named on stderr)."""
    proj = project.current()
    entries = scenario_catalogue(proj)
    if not entries:
        where = ", ".join(str(p) for p in proj.scenario_path)
        raise SpecError(f"no scenarios found (searched {where}); `kartci init` creates a project "
                        "with one")
    table = Table("scenario", "from", "description", box=None)
    for e in entries:
        table.add_row(Text(e.name), Text(e.origin.value),
                      Text(f"error: {e.error}", style="red") if e.error else Text(e.description))
    out_console.print(table)
    bad = [e.name for e in entries if e.error]
    if bad:
        raise SpecError(f"{len(bad)} of {len(entries)} scenario files cannot be loaded: "
                        f"{', '.join(bad)} (errors listed above)")
    exit_if_broken()


@app.command()
def show(name: Annotated[str, typer.Argument(help="A scenario name or YAML path.",
                                             autocompletion=complete_scenario)],
         set_: SetOpt = None, allow_outside_paths: AllowOutsideOpt = False) -> None:
    """Print a scenario fully resolved (world and model files included, overrides applied)."""
    with stdout_to_stderr():  # a plugin printing while it loads or validates: not into JSON
        spec = load_scenario(name, set_ or [], project=project.current(),
                             allow_outside_paths=allow_outside_paths)
    typer.echo(json.dumps(spec.model_dump(mode="json"), indent=2))


@app.command()
def schema(out: Annotated[Path | None, typer.Option(help="Write to this file.")] = None) -> None:
    """JSON Schema of scenario files, for editor completion and validation: with every
    registered plugin, the project's own included. Point a scenario at it with a first line
    `# yaml-language-server: $schema=<path relative to the scenario file>`."""
    if out is None:
        with stdout_to_stderr():  # a plugin printing while it loads: not into the JSON
            schema_doc = scenario_schema()
        typer.echo(json.dumps(schema_doc, indent=2))
    else:
        write_schema(out)


@app.command()
def plugins() -> None:
    """List the registered controllers, nodes, robots, worlds and metrics.

    Controllers, nodes, robot kinds, world kinds and metric sets (what a scenario can name), each
    with its one-line description and the module it comes from. Exit 1 when a plugin failed to
    load (listed as FAILED TO LOAD, and named on stderr)."""
    table = Table("kind", "name", "description", "from", box=None)
    for info in catalogue():
        table.add_row(Text(info.kind), Text(info.name), Text(info.description),
                      Text(info.source))
    out_console.print(table)
    exit_if_broken()


def exit_if_broken() -> None:
    """Exit 1 when a plugin failed to load, each named on stderr, as `pip check` does for a
    broken install: the listing above is shown all the same, but a script or CI job that
    checks the installation must not read it as healthy."""
    failed = broken()
    for plugin in failed:
        err_console.print(Text(f"kartci: error: {plugin.message}"), highlight=False,
                          soft_wrap=True)
    if failed:
        raise typer.Exit(1)
