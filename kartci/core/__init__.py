"""The contracts every part of kartci and every plugin is written against, and the registry
that names them: the bottom of the package graph, importing nothing of kartci's above it.

- `Agent`, `Outbox`: what a controller or node is (messages in, messages out).
- `Direction`, `Metric`, `MetricDef`: a metric's value and its definition.
- `Frozen` and the parameter bases (`ControllerParams`, `NodeParams`, `RobotParams`,
  `WorldParams`, `MetricParams`) that each plugin's own pydantic model extends.
- `Controller`, `Node`, `RobotKind` (with what kind-neutral code asks of a kind:
  `WheelOdometry`, `JoyCommand`, `SimReal`; `Outline`, a robot seen from above, convex `Polygon`
  parts; how its messages flatten into log tables: `Flattener`), `WorldKind`, `MetricSet`, with
  a `Protocol` for every function they hold (`RobotFactory`, `ComputeFn`, ...): the contracts,
  `kartci.core.kinds`.
- Their registries (`kartci.core.registry`); `Registries`, the five passed explicitly to what
  validates a scenario (`DEFAULT_REGISTRIES`: the process-wide ones); `broken()`: the plugins
  that failed to load; loading them (`kartci.core.loading`: `load(project)`, a `PluginSource`).
- `Channel`, `ControlSpace`: a robot kind's command and observation as vectors (`kartci.gym`).
- `RunFolder`: the one owner of a run folder's file names.
- `Fault`, `Change`: a fault a kind declares on its own parameters (`kartci faults`).
"""

from kartci.core.agent import Agent, Outbox
from kartci.core.control import Channel, ControlSpace, odometry_channels, odometry_values
from kartci.core.faults import Acts, Change, Fault, Op, unknown_keys
from kartci.core.kinds import (
    AgentContext,
    AgentFactory,
    ComputeFn,
    ControlFn,
    Controller,
    DataFolders,
    FiguresFn,
    FitModel,
    Flattener,
    JoyCommand,
    JoystickFn,
    MetricSet,
    Node,
    OdometryFn,
    Outline,
    OutlineFn,
    PlotsFn,
    Polygon,
    ReplayFn,
    RobotFactory,
    RobotKind,
    SimReal,
    WarningsFn,
    WheelOdometry,
    WorldFactory,
    WorldKind,
    fields,
    lazy,
)
from kartci.core.loading import BrokenPlugin, PluginSource, load
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
    DEFAULT_REGISTRIES,
    METRICS,
    NODES,
    REGISTRIES,
    ROBOTS,
    WORLDS,
    PluginInfo,
    Registries,
    Registry,
    broken,
    catalogue,
    definition,
    definitions,
    register,
)
from kartci.core.runfolder import UNFINISHED, RunFolder

__all__ = [
    "CONTROLLERS",
    "DEFAULT_REGISTRIES",
    "METRICS",
    "NODES",
    "REGISTRIES",
    "ROBOTS",
    "UNFINISHED",
    "WORLDS",
    "Acts",
    "Agent",
    "AgentContext",
    "AgentFactory",
    "BrokenPlugin",
    "Change",
    "Channel",
    "ComputeFn",
    "ControlFn",
    "ControlSpace",
    "Controller",
    "ControllerParams",
    "DataFolders",
    "Direction",
    "Fault",
    "FiguresFn",
    "FitModel",
    "Flattener",
    "Frozen",
    "JoyCommand",
    "JoystickFn",
    "Metric",
    "MetricDef",
    "MetricParams",
    "MetricSet",
    "Node",
    "NodeParams",
    "OdometryFn",
    "Op",
    "Outbox",
    "Outline",
    "OutlineFn",
    "PlotsFn",
    "PluginInfo",
    "PluginSource",
    "Polygon",
    "Registries",
    "Registry",
    "ReplayFn",
    "RobotFactory",
    "RobotKind",
    "RobotParams",
    "RunFolder",
    "SimReal",
    "WarningsFn",
    "WheelOdometry",
    "WorldFactory",
    "WorldKind",
    "WorldParams",
    "broken",
    "catalogue",
    "definition",
    "definitions",
    "fields",
    "lazy",
    "load",
    "odometry_channels",
    "odometry_values",
    "register",
    "unknown_keys",
]
