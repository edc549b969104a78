"""Joystick mappings (source document, Sec. 5.1.2): which Joy axes and buttons mean throttle, brake,
steering, reverse and emergency stop. One YAML file per controller in models/gokart/joy/.
The kart's own: its controllers, the bridge and log import turn Joy into `KartInput` here."""

from __future__ import annotations

import os
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from kartci.core import AgentContext, JoyCommand, RobotParams
from kartci.errors import SpecError, did_you_mean
from kartci.logs import messages
from kartci.logs.types import header, msg, stamp_ns, typestore
from kartci.project import BUILTIN_MODELS
from kartci.robots.gokart.params import GokartModel
from kartci.robots.gokart.steering import KartInput
from kartci.scenario.yamlio import read_yaml


class _M(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class SteeringAxis(_M):
    """The Joy axis that steers; the steering-column angle is linear in it (+1: full left)."""

    axis: int = Field(ge=0)
    scale_rad: float = Field(description="steering-column angle at axis value +1 (full left)")


class PedalAxis(_M):
    """A pedal on a Joy axis: its value released (`rest`) and fully pressed (`full`); in between it
    maps linearly to 0..1."""

    axis: int = Field(ge=0)
    rest: float = 1.0
    full: float = -1.0


class Button(_M):
    """A Joy button by index; pressed while its value is non-zero."""

    button: int = Field(ge=0)


class JoyMapping(_M):
    """How one make of controller's Joy messages map to kart inputs, and the axis and button counts
    its messages have (a pad of another make is refused)."""

    name: str
    steering: SteeringAxis
    throttle: PedalAxis
    brake: PedalAxis
    reverse: Button
    emergency_stop: Button
    axes: int = Field(ge=1, description="axes in a Joy message of this controller")
    buttons: int = Field(ge=1)


def model_folders(ctx: AgentContext) -> tuple[Path, ...]:
    """The robot model folders of the project an agent runs in (`AgentContext.project`), where
    a mapping name is looked up; kartci's own for a scenario built by hand."""
    return ctx.project.model_path if ctx.project is not None else (BUILTIN_MODELS,)


def known_mappings(models: tuple[Path, ...]) -> dict[str, Path]:
    """Mapping name -> file, from `gokart/joy/` in the robot model folders `models` (a
    project's `model_path`: its own folders first, then the built-in ones); `.yaml` and `.yml`
    alike."""
    found: dict[str, Path] = {}
    for folder in models:
        for p in sorted((folder / "gokart" / "joy").glob("*.y*ml")):
            if p.suffix in (".yaml", ".yml"):
                found.setdefault(p.stem, p)
    return dict(sorted(found.items()))


@cache
def load_mapping(name: str, models: tuple[Path, ...]) -> JoyMapping:
    """A mapping by name (`gokart/joy/<name>.yaml` or `.yml` in the model folders `models`) or
    by path to a YAML file (anything ending in .yaml / .yml or holding a path separator)."""
    if name.endswith((".yaml", ".yml")) or "/" in name or os.sep in name:
        path = Path(name).expanduser()
        return _parse(path)  # read_yaml names a missing file, a FIFO, a device
    known = known_mappings(models)
    if name not in known:
        raise SpecError(f"unknown joystick mapping '{name}'{did_you_mean(name, known)}; "
                        "or give the path of a mapping YAML file")
    return _parse(known[name])


def _parse(path: Path) -> JoyMapping:
    """The mapping in a file; a problem is named by its place (key, or line and column), never
    by quoting the file, which may be anything a user pointed at. Read as scenario files are
    (yamlio: a small regular file, no duplicate keys)."""
    data = read_yaml(path)
    try:
        return JoyMapping.model_validate(data)
    except ValidationError as err:
        first = err.errors()[0]
        key = ".".join(str(x) for x in first["loc"]) or "(top level)"
        raise SpecError(f"{path}: invalid joystick mapping ({key}: {first['msg']})") from err


def check_pad(m: JoyMapping, name: str, log: Path, topic: str, models: tuple[Path, ...]
              ) -> None:
    """The recorded pad must have the mapping's axis and button counts: a pad of another make
    would otherwise be read with the wrong axes, silently."""
    for _, _, joy in messages(log, [topic]):
        check_counts(m, name, joy, f"{log} {topic}", models)
        return


def check_counts(m: JoyMapping, name: str, joy: Any, where: str, models: tuple[Path, ...]
                 ) -> None:
    """One Joy message against the mapping's counts (SpecError, one line, when they differ)."""
    axes, buttons = len(joy.axes), len(joy.buttons)
    if (axes, buttons) != (m.axes, m.buttons):
        raise SpecError(f"{where}: the pad has {axes} axes and {buttons} buttons, but mapping "
                        f"'{name}' ({m.name}) expects {m.axes} axes and {m.buttons} buttons; "
                        "choose a matching mapping (known: "
                        f"{', '.join(known_mappings(models))}) or give the path of your own "
                        "mapping file")


def _pedal(p: PedalAxis, axes: Any) -> float:
    v = float(axes[p.axis]) if p.axis < len(axes) else p.rest
    return _unit((v - p.rest) / (p.full - p.rest))


def _unit(x: float) -> float:
    """`np.clip(x, 0.0, 1.0)` as numpy's clip compares (NaN and -0.0 kept), a twentieth of its
    time on a float (two a control tick)."""
    if x != x:  # NaN
        return x
    x = x if x >= 0.0 else 0.0
    return x if x <= 1.0 else 1.0


def to_command(m: JoyMapping, model: GokartModel, joy: Any) -> KartInput:
    """A Joy message as a kart command, scaled to the kart's limits."""
    axes, buttons = joy.axes, joy.buttons
    steer = float(axes[m.steering.axis]) if m.steering.axis < len(axes) else 0.0

    def pressed(b: Button) -> bool:
        return b.button < len(buttons) and bool(buttons[b.button])

    return KartInput(steering_rad=steer * m.steering.scale_rad,
                     accel_mps2=_pedal(m.throttle, axes) * model.max_accel_mps2,
                     brake_mps2=_pedal(m.brake, axes) * model.max_brake_mps2,
                     reverse=pressed(m.reverse), estop=pressed(m.emergency_stop))


def to_joy(m: JoyMapping, model: GokartModel, cmd: KartInput, t_ns: int, frame: str) -> Any:
    """The Joy message a person would produce for a command (the inverse of to_command)."""
    axes = np.zeros(m.axes, dtype=np.float32)
    buttons = np.zeros(m.buttons, dtype=np.int32)
    axes[m.steering.axis] = np.clip(cmd.steering_rad / m.steering.scale_rad, -1, 1)
    for pedal, value, limit in ((m.throttle, cmd.accel_mps2, model.max_accel_mps2),
                                (m.brake, cmd.brake_mps2, model.max_brake_mps2)):
        frac = float(np.clip(value / limit, 0.0, 1.0))
        axes[pedal.axis] = pedal.rest + frac * (pedal.full - pedal.rest)
    buttons[m.reverse.button] = int(cmd.reverse)
    buttons[m.emergency_stop.button] = int(cmd.estop)
    return msg("sensor_msgs/msg/Joy", header=header(t_ns, frame), axes=axes, buttons=buttons)


def joystick(model: RobotParams, mapping: str, models: tuple[Path, ...]) -> JoyCommand:
    """The kart's `RobotKind.joystick`: a Joy message through `mapping` (a name looked up in
    the model folders `models`) to the `cmd` (kartci_msgs/KartCommand) it means, stamped with
    the Joy's time."""
    m = load_mapping(mapping, models)
    assert isinstance(model, GokartModel)  # a kind is asked only about its own robots

    def command(joy: Any, frame: str) -> tuple[str, Any]:
        return "cmd", kart_command(to_command(m, model, joy), stamp_ns(joy.header), frame)

    return command


def kart_command(cmd: KartInput, t_ns: int, frame: str) -> Any:
    """A command as the source document's kartci_msgs/KartCommand, stamped `t_ns` in `frame`."""
    return typestore().types["kartci_msgs/msg/KartCommand"](  # fields in the .msg's order
        header(t_ns, frame), cmd.steering_rad, cmd.accel_mps2, cmd.brake_mps2, cmd.reverse,
        cmd.estop)
