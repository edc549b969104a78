"""Model predictive contouring control for the go-kart: model, NLP, compiled-solver cache,
per-stage references with obstacles, and the solve loop.

The public names load on first use: the controller's parameter model (`mpcc.params`) is
imported with every registry, and the solver would bring CasADi (0.1 s) to every command."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from kartci.robots.gokart.mpcc.controller import Mpcc, Plan
    from kartci.robots.gokart.mpcc.reference import Obstacle, obstacle_from_xy

_WHERE = {"Mpcc": "controller", "Plan": "controller", "Obstacle": "reference",
          "obstacle_from_xy": "reference"}


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use."""
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"{__name__}.{where}"), name)


__all__ = ["Mpcc", "Obstacle", "Plan", "obstacle_from_xy"]
