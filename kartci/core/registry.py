"""Registries: every controller, node, robot kind, world kind and metric set, by name.

A team adds its own the same way kartci's built-ins are added: an entry point in the groups
`kartci.controllers`, `kartci.nodes`, `kartci.robots`, `kartci.worlds` and `kartci.metrics` whose
object is a `Controller`, `Node`, `RobotKind`, `WorldKind` or `MetricSet` (the contracts:
`kartci.core.kinds`), or a module named in the project's `plugins` list that calls
`register(...)`. Scenarios name them (`controller: {type: NAME}`, `nodes: {NAME: {...}}`,
`model: {kind: NAME}`, `world: {kind: NAME}`, `metrics: {NAME: {...}}`); each validates its own
parameters with its own pydantic model. The registry knows only the contracts, never an
implementation: built-ins are named by module strings (`lazy`) or entry points, so nothing here
imports them; `kartci.core.loading` fills the registries on first use.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field
from typing import Any, Generic, TypeVar

from kartci.core import loading
from kartci.core.kinds import Controller, MetricSet, Node, RobotKind, WorldKind
from kartci.core.metric import MetricDef
from kartci.errors import PluginError, SpecError, did_you_mean

T = TypeVar("T", Controller, Node, RobotKind, WorldKind, MetricSet)


@dataclass
class Registry(Generic[T]):
    """Plugins of one kind by name; filled from entry points and project plugins on first use."""

    group: str  # entry-point group
    what: str  # for messages: "controller", "robot kind", ...
    kind: type[T]
    items: dict[str, T] = field(default_factory=dict)
    sources: dict[str, str] = field(default_factory=dict)  # name -> where it was registered
    broken: dict[str, loading.BrokenPlugin] = field(default_factory=dict)  # failed entry points

    def register(self, item: T, replace: bool = False, source: str = "") -> T:
        """Add one plugin; the same name twice is an error unless `replace`."""
        if not isinstance(item, self.kind):
            raise SpecError(f"{self.group}: {item!r} is not a kartci.core."
                            f"{self.kind.__name__}")
        old = self.items.get(item.name)
        if old is not None and old != item and not replace:
            raise SpecError(f"two different {self.what}s are registered as '{item.name}'")
        self.items[item.name] = item
        if source or item.name not in self.sources:
            self.sources[item.name] = source or caller_module()
        return item

    def get(self, name: str) -> T:
        """The plugin of that name; a PluginError when it (or a project plugin module, which
        might have registered it) failed to load, a SpecError naming the known ones otherwise.
        Only the entry points of that name are imported when they provide it (see
        `loading.load_named`); anything else loads every plugin first, as `load` does."""
        if not loading.load_named(self, name):
            loading.load()
        item = self.items.get(name)
        if item is not None:
            return item
        if name in self.broken:
            raise self.broken[name].failure()
        module = next(iter(loading.BROKEN_MODULES.values()), None)
        if module is not None:  # a project module that failed may be the one registering it
            raise PluginError(f"unknown {self.what} '{name}'; {module.message}", module.trace)
        raise SpecError(f"unknown {self.what} '{name}'{did_you_mean(name, self.items)}")

    def names(self) -> list[str]:
        """Every registered name, sorted."""
        loading.load()
        return sorted(self.items)

    def all(self) -> list[T]:
        """Every registered plugin, by name."""
        loading.load()
        return [self.items[n] for n in sorted(self.items)]


CONTROLLERS: Registry[Controller] = Registry("kartci.controllers", "controller", Controller)
NODES: Registry[Node] = Registry("kartci.nodes", "node", Node)
ROBOTS: Registry[RobotKind] = Registry("kartci.robots", "robot kind", RobotKind)
WORLDS: Registry[WorldKind] = Registry("kartci.worlds", "world kind", WorldKind)
METRICS: Registry[MetricSet] = Registry("kartci.metrics", "metric set", MetricSet)
REGISTRIES: tuple[Registry[Any], ...] = (CONTROLLERS, NODES, ROBOTS, WORLDS, METRICS)


@dataclass(frozen=True)
class Registries:
    """The registries a scenario is validated against, handed to its validators in pydantic's
    validation context (`kartci.scenario.dispatch.context`), never looked up by them: a caller
    may validate against others (a subset, a test's) while the process-wide ones stay as
    they are."""

    controllers: Registry[Controller]
    nodes: Registry[Node]
    robots: Registry[RobotKind]
    worlds: Registry[WorldKind]
    metrics: Registry[MetricSet]


# the process-wide registries, filled from entry points and the project's plugins
DEFAULT_REGISTRIES = Registries(CONTROLLERS, NODES, ROBOTS, WORLDS, METRICS)


def register(item: Controller | Node | RobotKind | WorldKind | MetricSet) -> None:
    """Register a plugin from Python (a project plugin module, a test)."""
    for reg in REGISTRIES:
        if isinstance(item, reg.kind):
            reg.register(item, source=caller_module())
            return
    raise SpecError(f"cannot register {item!r}: not a Controller, Node, RobotKind, WorldKind "
                    "or MetricSet")


def caller_module() -> str:
    """The module that called into this one (for `kartci plugins`: where a plugin came from)."""
    frame = sys._getframe(1)
    while frame is not None and frame.f_globals.get("__name__") == __name__:
        frame = frame.f_back  # type: ignore[assignment]
    return str(frame.f_globals.get("__name__", "?")) if frame is not None else "?"


@dataclass(frozen=True)
class PluginInfo:
    """One registered plugin, as `kartci plugins` lists it."""

    kind: str  # "controller", "node", "robot kind", "world kind", "metric set"
    name: str
    description: str
    source: str  # the module that registered it (and the distribution, for entry points)


def catalogue(project: loading.PluginSource | None = None) -> list[PluginInfo]:
    """Every registered plugin of every kind, installed ones and the project's own."""
    loading.load(project)
    found = [PluginInfo(reg.what, name, item.description, reg.sources.get(name, "?"))
             for reg in REGISTRIES for name, item in sorted(reg.items.items())]
    found += [PluginInfo(reg.what, name, f"FAILED TO LOAD: {b.error}", b.where)
              for reg in REGISTRIES for name, b in sorted(reg.broken.items())]
    return found + [PluginInfo("plugin module", b.name, f"FAILED TO LOAD: {b.error}", b.where)
                    for b in loading.BROKEN_MODULES.values()]


def broken() -> list[loading.BrokenPlugin]:
    """Every plugin that failed to load (all are loaded first), entry points then project
    modules: what a command reports once before running what does not need them."""
    loading.load()
    return [*(b for reg in REGISTRIES for _, b in sorted(reg.broken.items())),
            *loading.BROKEN_MODULES.values()]


def definitions(metrics: Registry[MetricSet] = METRICS) -> dict[str, MetricDef]:
    """Every registered metric's definition by name."""
    out: dict[str, MetricDef] = {}
    for mset in metrics.all():
        for name, d in mset.defs.items():
            out.setdefault(name, d)
    return out


def definition(name: str) -> MetricDef | None:
    """The definition of a metric (`name` or `agent.name`), or None for an unknown one. The
    sets already loaded are asked first (a scored metric's own set: no need to import every
    plugin); the sets that define a name alike give the same definition."""
    base = name.rsplit(".", 1)[-1]
    for key in sorted(METRICS.items):
        found = METRICS.items[key].defs.get(base)
        if found is not None:
            return found
    return definitions().get(base)
