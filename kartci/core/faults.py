"""Faults a kind can inject into a scenario: the contract of `kartci faults` (issue 42).

A fault is a named set of changes to a scenario's own keys, declared by what owns the keys:
a robot kind on its model and sensors (`model.motor_power_w`, `sensors.imu.enabled`), a
controller or node type on its own parameters (`kp`, `weights.progress`), a world kind on its
parameters (`floor_friction`). Each change becomes a `--set` assignment, so the scenario's own
validation refuses a key that does not exist or a value it cannot take; `unknown_keys` checks
the keys against the owner's parameter models before any scenario is loaded. Nothing here
simulates: a fault only acts through parameters the simulation reads.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from pydantic import BaseModel

Scalar = float | int | bool | str


class Op(StrEnum):
    """How a change sets its key."""

    SCALE = "scale"  # the scenario's value times `value`
    SET = "set"  # `value`, whatever the scenario's
    ADD = "add"  # the scenario's value plus `value`


@dataclass(frozen=True)
class Change:
    """One key of a fault: a dotted key below the owner's scope, and how it changes."""

    key: str
    op: Op
    value: Scalar

    @classmethod
    def scale(cls, key: str, factor: float) -> Change:
        """The scenario's value of `key` times `factor`."""
        return cls(key, Op.SCALE, factor)

    @classmethod
    def to(cls, key: str, value: Scalar) -> Change:
        """`key` set to `value`."""
        return cls(key, Op.SET, value)

    @classmethod
    def add(cls, key: str, amount: float) -> Change:
        """The scenario's value of `key` plus `amount`."""
        return cls(key, Op.ADD, amount)


@dataclass(frozen=True)
class Acts:
    """What a fault does to one target (an agent or the world): the `--set` assignments, or,
    when it does nothing there, why not (then `overrides` is empty)."""

    overrides: tuple[str, ...] = ()
    why_not: str = ""


Read = Callable[[str], Any]  # a full dotted key -> the scenario's validated value (None: unset)


@dataclass(frozen=True)
class Fault:
    """A named fault. `when`: keys (in the same scope) that must be true for it to act (a
    sensor's `enabled`); `read_by`: for a robot's sensor, the node types that read it (the
    fault acts only on an agent that runs one: a controller that drives from ground truth
    never sees a noisy IMU); `catalogues`: the catalogues that list it (`kartci faults
    --catalogue NAME`)."""

    name: str  # unique within its owner; `kartci faults` names it `<owner>.<name>`
    description: str
    changes: tuple[Change, ...]
    when: tuple[str, ...] = ()
    catalogues: tuple[str, ...] = ("standard",)
    read_by: tuple[str, ...] = ()

    def acts(self, read: Read, prefix: str) -> Acts:
        """The assignments that inject it into one target, whose keys start with `prefix`
        (`agents.kart0.`, `agents.kart0.controller.`, `world.`)."""
        for key in self.when:
            if not read(prefix + key):
                return Acts(why_not=f"{prefix}{key} is off")
        if self.read_by and all(read(f"{prefix}nodes.{n}") is None for n in self.read_by):
            return Acts(why_not=f"nothing reads it: {prefix}nodes has no "
                                f"{' or '.join(self.read_by)}")
        out = []
        for c in self.changes:
            full = prefix + c.key
            old = read(full)
            if c.op is Op.SET:
                new: Scalar = c.value
            elif not _number(old):
                return Acts(why_not=f"{full} is {'not set' if old is None else repr(old)}: "
                                    f"nothing to {c.op.value}")
            else:
                assert isinstance(c.value, int | float)
                new = old * c.value if c.op is Op.SCALE else old + c.value
                new = int(new) if isinstance(old, int) and float(new).is_integer() else new
            if new == old:
                return Acts(why_not=f"{full} is already {_text(old)}")
            out.append(f"{full}={_text(new)}")
        return Acts(tuple(out))


def _number(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _text(x: object) -> str:
    """A value as a `--set` right-hand side (YAML): 12 significant digits for a float."""
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, float):
        return f"{x:.12g}"
    return str(x)


def unknown_keys(fault: Fault, roots: Mapping[str, type[BaseModel] | None]) -> list[str]:
    """The keys of a fault (changes and `when`) that its owner's parameter models lack.
    `roots`: the model at each first part of a key (`{"model": GokartModel, "sensors":
    KartSensors}`), or at `""` for keys that start in the model itself (a world's)."""
    bad = []
    for key in (*(c.key for c in fault.changes), *fault.when):
        head, _, rest = key.partition(".")
        model: type[BaseModel] | None
        if "" in roots:
            model, parts = roots[""], key.split(".")
        else:
            model, parts = roots.get(head), rest.split(".") if rest else []
            if head not in roots or not parts:
                bad.append(key)
                continue
        if model is None or not _has(model, parts):
            bad.append(key)
    return bad


def _has(model: type[BaseModel], parts: list[str]) -> bool:
    """Whether `model` has the nested field `parts` (through fields whose type is a model)."""
    field = model.model_fields.get(parts[0])
    if field is None:
        return False
    if len(parts) == 1:
        return True
    sub = field.annotation
    return isinstance(sub, type) and issubclass(sub, BaseModel) and _has(sub, parts[1:])
