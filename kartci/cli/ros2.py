"""`kartci ros2`: the ROS 2 Python the DDS bridge runs under, and the Fast DDS profile a team's
own launch uses to meet kartci on shared memory."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Annotated

import typer

from kartci.bridge.dds import env as ros_env
from kartci.bridge.dds.env import profile_path
from kartci.cli.common import app
from kartci.errors import SpecError

ros2_app = typer.Typer(help="The ROS 2 side of `middleware: dds` (rclpy in its own Python).",
                       no_args_is_help=True, rich_markup_mode=None)
app.add_typer(ros2_app, name="ros2")


@ros2_app.command("env")
def ros2_env(
    path: Annotated[Path | None, typer.Argument(help="Folder of the venv (default: in "
                                                "kartci's cache folder).")] = None,
) -> None:
    """Make (or complete) a venv with rclpy on Fast DDS and the standard messages from the
    ros-rclpy wheels (ROS 2 Kilted, CPython 3.11, about 270 MB), kept apart from kartci's own
    environment; print its Python. $KARTCI_ROS2_PYTHON names a team's own ROS 2 Python instead."""
    target = path or ros_env.default_path()
    t0 = time.perf_counter()
    python = ros_env.make(target)
    typer.echo(f"{python}  (made in {time.perf_counter() - t0:.0f} s; "
               f"{'pass it as $' + ros_env.PYTHON_ENV if path else 'found by kartci'})")


@ros2_app.command("python")
def ros2_python() -> None:
    """The ROS 2 Python `middleware: dds` would use; exit 2 when there is none or it does not
    import rclpy."""
    python = ros_env.require_python()
    why = ros_env.probe(python)
    if why is not None:
        raise SpecError(why)
    typer.echo(str(python))


@ros2_app.command("profile")
def ros2_profile() -> None:
    """The path of kartci's shared-memory-only Fast DDS profile (for
    FASTDDS_DEFAULT_PROFILES_FILE in a team's own launch)."""
    typer.echo(str(profile_path()))
