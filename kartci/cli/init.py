"""`kartci init`: make a folder a kartci project (see `kartci.scaffold`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from kartci.cli.common import app, err_console, out_console
from kartci.scaffold import init_project, install_source


@app.command()
def init(
    folder: Annotated[Path, typer.Argument(
        help="The project folder, e.g. your repository's root (created if missing).")]
    = Path(),
    force: Annotated[bool, typer.Option(
        "--force", help="Overwrite files kartci writes (kartci.toml, the scenario, the "
                        "workflow, constraints.txt, baselines/README.md).")] = False,
    kartci: Annotated[str | None, typer.Option(
        "--kartci", metavar="SPEC",
        help="What the gate installs: a version spec (kartci==0.1.0), a wheel's path or URL, "
             "or 'kartci @ git+URL@COMMIT'. Default: this kartci (its git commit, its wheel's "
             "URL, or its wheel file copied into .kartci/wheels/).")] = None,
) -> None:
    """Make FOLDER a kartci project.

    Writes kartci.toml (or adds [tool.kartci] to an existing pyproject.toml), scenarios/ with
    one short scenario, baselines/, the gate workflow .github/workflows/kartci.yml,
    constraints.txt, a README section and a .gitignore line. The gate installs this kartci
    (or --kartci); a warning says when that may install nothing. Refuses to overwrite an
    existing file unless --force."""
    install = install_source(kartci)
    steps = init_project(folder, force, install)
    out_console.print(f"kartci project in {folder.resolve()}:", markup=False, highlight=False)
    for step in steps:
        out_console.print(f"  {step.action.value:12s} {step.path}", markup=False, highlight=False)
    out_console.print("next: `kartci run` (every metric is NEW until there is a baseline), then "
                      "`kartci baseline update reports/latest` and commit baselines/",
                      markup=False, highlight=False)
    out_console.print(f"the gate installs: {install.requirement}", markup=False, highlight=False)
    if install.warning:
        err_console.print(f"kartci: warning: {install.warning}", markup=False, highlight=False,
                          soft_wrap=True)
