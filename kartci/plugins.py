"""Deprecated: import from `kartci.core` (the contracts and the registries); `ScoreContext`
from `kartci.metrics`.

The public path plugin authors use (README "Extending", docs/tutorial.md, examples/): every
name here is `kartci.core`'s own object, so registering through either path is the same.
Nothing in kartci imports this module.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from kartci.core import (
    CONTROLLERS,
    METRICS,
    NODES,
    REGISTRIES,
    ROBOTS,
    WORLDS,
    Agent,
    AgentContext,
    Controller,
    ControllerParams,
    Direction,
    Metric,
    MetricDef,
    MetricParams,
    MetricSet,
    Node,
    NodeParams,
    PluginInfo,
    Registry,
    RobotKind,
    RobotParams,
    WorldKind,
    WorldParams,
    catalogue,
    lazy,
    load,
    register,
)

if TYPE_CHECKING:
    from kartci.metrics import ScoreContext

__all__ = [
    "CONTROLLERS",
    "METRICS",
    "NODES",
    "REGISTRIES",
    "ROBOTS",
    "WORLDS",
    "Agent",
    "AgentContext",
    "Controller",
    "ControllerParams",
    "Direction",
    "Metric",
    "MetricDef",
    "MetricParams",
    "MetricSet",
    "Node",
    "NodeParams",
    "PluginInfo",
    "Registry",
    "RobotKind",
    "RobotParams",
    "ScoreContext",
    "WorldKind",
    "WorldParams",
    "catalogue",
    "lazy",
    "load",
    "register",
]


def __getattr__(name: str) -> Any:
    """`ScoreContext` (what a metric set's `compute` is given) without importing pandas here."""
    if name == "ScoreContext":
        from kartci.metrics import ScoreContext

        return ScoreContext
    raise AttributeError(f"module 'kartci.plugins' has no attribute '{name}'")
