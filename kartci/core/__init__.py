"""The contracts every part of kartci and every plugin is written against, and the registry
that names them: the bottom of the package graph, importing nothing of kartci's above it.

- `Agent`, `Outbox`: what a controller or node is (messages in, messages out).
- `Direction`, `Metric`, `MetricDef`: a metric's value and its definition.
- `Frozen` and the parameter bases (`ControllerParams`, `NodeParams`, `RobotParams`,
  `WorldParams`, `MetricParams`) that each plugin's own pydantic model extends.
- `Controller`, `Node`, `RobotKind`, `WorldKind`, `MetricSet` and their registries;
  `Outline` (a robot seen from above, convex `Polygon` parts), what a robot kind declares.
- `RunFolder`: the one owner of a run folder's file names.
"""

from kartci.core.agent import Agent, Outbox
from kartci.core.metric import Direction, Metric, MetricDef
from kartci.core.params import (
    ControllerParams,
    Frozen,
    MetricParams,
    NodeParams,
    RobotParams,
    WorldParams,
)
from kartci.core.registry import (
    CONTROLLERS,
    METRICS,
    NODES,
    REGISTRIES,
    ROBOTS,
    WORLDS,
    AgentContext,
    Controller,
    MetricSet,
    Node,
    Outline,
    PluginInfo,
    Polygon,
    Registry,
    RobotKind,
    WorldKind,
    catalogue,
    definition,
    definitions,
    lazy,
    load,
    register,
)
from kartci.core.runfolder import UNFINISHED, RunFolder

__all__ = [
    "CONTROLLERS",
    "METRICS",
    "NODES",
    "REGISTRIES",
    "ROBOTS",
    "UNFINISHED",
    "WORLDS",
    "Agent",
    "AgentContext",
    "Controller",
    "ControllerParams",
    "Direction",
    "Frozen",
    "Metric",
    "MetricDef",
    "MetricParams",
    "MetricSet",
    "Node",
    "NodeParams",
    "Outbox",
    "Outline",
    "PluginInfo",
    "Polygon",
    "Registry",
    "RobotKind",
    "RobotParams",
    "RunFolder",
    "WorldKind",
    "WorldParams",
    "catalogue",
    "definition",
    "definitions",
    "lazy",
    "load",
    "register",
]
