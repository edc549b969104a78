"""The consoles, shared options and default output folder every `kartci` command is built
from: kartci's own (`kartci.cli`) and those a robot kind or plugin brings (entry points
`kartci.commands`). Below every package that brings commands, so a kind's commands import
nothing above it (`kartci.cli` is above them all)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console

from kartci import project

# In CI logs (no terminal) rich would wrap at 80 columns and cut metric names: use 160.
out_console = Console(width=None if sys.stdout.isatty() else 160)
err_console = Console(stderr=True, width=None if sys.stderr.isatty() else 160)

SetOpt = Annotated[list[str] | None, typer.Option(
    "--set", help="Override a scenario value: dotted.key=value (repeatable).")]
OutOpt = Annotated[Path | None, typer.Option(
    "--out", "-o", help="Output folder [default: the project's reports/<command>].")]
AllowOutsideOpt = Annotated[bool, typer.Option(
    "--allow-outside-paths", help="Let data files (tracks, worlds, models, maps, joystick "
    "mappings, a scenario's or profile's log and track; absolute paths, '..', symlinks) lie "
    "outside the project and kartci's data.")]


def command_project() -> project.Project:
    """The project a command runs in (the working directory's, or the one `KARTCI_ROOT`
    names): an entry point reads it here and hands it down; nothing below looks it up."""
    return project.current()


def out_dir(out: Path | None, name: str) -> Path:
    """`--out`, or `<the project's reports folder>/<name>` (a SpecError when no project was
    found: see `Project.default_output`)."""
    return out if out is not None else command_project().default_output(name)
