"""Registries: every controller, node, robot kind, world kind and metric set, by name.

A team adds its own the same way kartci's built-ins are added: an entry point in the groups
`kartci.controllers`, `kartci.nodes`, `kartci.robots`, `kartci.worlds` and `kartci.metrics` whose
object is a `Controller`, `Node`, `RobotKind`, `WorldKind` or `MetricSet`, or a module named in
the project's `plugins` list that calls `register(...)`. Scenarios name them
(`controller: {type: NAME}`, `nodes: {NAME: {...}}`, `model: {kind: NAME}`,
`world: {kind: NAME}`, `metrics: {NAME: {...}}`); each validates its own parameters with its own
pydantic model. The registry knows only the contracts (`kartci.core`), never an implementation:
built-ins are named by module strings (`lazy`) or entry points, so nothing here imports them.
"""

from __future__ import annotations

import contextlib
import importlib
import os
import sys
import traceback
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from functools import cache
from importlib.metadata import EntryPoints, entry_points
from pathlib import Path
from typing import Any, ClassVar, Generic, TypeVar

from kartci import project as project_mod
from kartci.core.agent import Agent
from kartci.core.control import ControlSpace
from kartci.core.metric import Metric, MetricDef
from kartci.core.params import (
    ControllerParams,
    Frozen,
    MetricParams,
    NodeParams,
    RobotParams,
    WorldParams,
)
from kartci.errors import PluginError, SpecError
from kartci.project import Project, did_you_mean


@dataclass(frozen=True)
class AgentContext:
    """What a controller is told when it is built: who it is and which robot it drives.
    Everything else it learns from messages."""

    name: str
    model: RobotParams
    others: tuple[str, ...] = ()  # the other agents of the scenario (their topics: /<name>/...)
    run_dir: Path | None = None  # where the run's files go (a controller's own output files)
    world: WorldParams | None = None  # the scenario's world: the map a real robot would carry


P = TypeVar("P", ControllerParams, NodeParams)


@dataclass(frozen=True)
class _AgentType(Generic[P]):
    """What controllers and nodes share: a parameter model, a factory
    `(params, context) -> Agent` and the robot kinds it works with (empty: any)."""

    name: str
    params: type[P]
    factory: Callable[[Any, AgentContext], Agent]
    robots: tuple[str, ...] = ()
    description: str = ""
    # instead of naming kinds: it works with every registered kind this is true of (a kind-
    # neutral agent states what it needs of a robot: the topics it reads, its wheel odometry)
    fits: Callable[[RobotKind], bool] | None = None
    works_on: ClassVar[str] = "works with"  # the verb of the wrong-robot error

    def kinds(self) -> tuple[str, ...]:
        """The robot kinds it works with (empty and no `fits`: any)."""
        if self.fits is None:
            return self.robots
        return tuple(k.name for k in ROBOTS.all() if self.fits(k))

    def build(self, params: P, ctx: AgentContext) -> Agent:
        """The agent for one robot; a SpecError when it cannot work with that robot's kind."""
        kinds = self.kinds()
        if (kinds or self.fits is not None) and ctx.model.kind not in kinds:
            raise SpecError(f"agent {ctx.name}: {type(self).__name__.lower()} {self.name} "
                            f"{self.works_on} {' or '.join(kinds) or 'no registered'} robots, "
                            f"not {ctx.model.kind}")
        return self.factory(params, ctx)


@dataclass(frozen=True)
class Controller(_AgentType[ControllerParams]):
    """A controller type: what drives a robot (`agents.<name>.controller: {type: NAME}`)."""

    # (run log, parameter names, output folder) -> lines to show: fits the controller's own
    # prediction model to a log and writes the result there (`kartci calibrate --mpcc`)
    fit: Callable[[Path, list[str], Path], list[str]] | None = None
    works_on: ClassVar[str] = "drives"


@dataclass(frozen=True)
class Node(_AgentType[NodeParams]):
    """A node type: a helper that runs beside a robot's controller (localization, a detector),
    as an `Agent` in the robot's namespace, stepped before the controller at the same tick so
    the controller reads its output. A scenario lists them: `agents.<name>.nodes: {NAME: {...}}`."""

    works_on: ClassVar[str] = "runs on"


Polygon = tuple[tuple[float, float], ...]  # corners (x, y), m, counter-clockwise
Outline = tuple[Polygon, ...]  # a robot seen from above: convex parts, in its body frame


@dataclass(frozen=True)
class WheelOdometry:
    """Forward speed from a robot's `joint_states`: the mean spin of these wheel joints (rad/s)
    times their radius."""

    joints: tuple[str, ...]
    radius_m: float


@dataclass(frozen=True)
class SimReal:
    """How `kartci simreal` replays a real log of a robot kind into its simulation."""

    scenario: str  # the scenario simulated when neither the command line nor the profile names one
    commands: tuple[str, ...]  # message types a log's commands may have
    wheel_speeds: bool = False  # Twist commands become wheel speeds (a differential drive's base)


Flattener = Callable[[Any], dict[str, Any]]  # a decoded message -> its columns in a log table


def fields(*names: str) -> Flattener:
    """The flattener that copies these fields of a message into its row."""
    return lambda m: {n: getattr(m, n) for n in names}


# (sensor_msgs/Joy, frame to stamp with) -> the (topic, message) that commands the robot
JoyCommand = Callable[[Any, str], tuple[str, Any]]


@dataclass(frozen=True)
class RobotKind:
    """A robot kind: its parameter model, the simulated robot, its metric sets and plots, and
    what kind-neutral code (nodes, the bridge, real-log import, the CLI) asks of it instead of
    naming it."""

    name: str
    params: type[RobotParams]
    factory: Callable[..., Any]  # (RobotContext) -> sim Robot; see kartci.sim.robot
    metrics: tuple[str, ...] = ()  # metric sets computed for every agent of this kind
    plots: Callable[..., Any] | None = None  # (PlotContext) -> results.Plots
    description: str = ""
    sensors: type[Frozen] | None = None  # the robot's sensor specs (agents.<name>.sensors)
    # (model, its URDF text as a log recorded it, or None: the model's file) -> the robot seen
    # from above in base_link, m: what clearance, detection ground truth and other robots'
    # lidar see of a robot of this kind (None: a point at base_link)
    outline: Callable[[Any, str | None], Outline] | None = None
    publishes: tuple[str, ...] = ()  # topics its sensors can publish in its namespace (`imu`)
    accepts: tuple[str, ...] = ()  # command topics it applies (`cmd_vel`, `wheel_cmd`)
    odometry: Callable[[Any], WheelOdometry] | None = None  # (params) -> its wheel odometry
    joystick: Callable[[Any, str], JoyCommand] | None = None  # (params, mapping name)
    # (log, topic, message type, joystick mapping) -> the ControllerParams that replay that
    # recorded input into a robot of this kind (`kartci replay`); checks the log first
    replay: Callable[[Path, str, str, str], ControllerParams] | None = None
    simreal: SimReal | None = None
    # (params) -> its command and observation as vectors, for a learning loop (kartci.gym)
    control: Callable[[Any], ControlSpace] | None = None
    # what only this kind knows of its own messages: how a log's tables flatten them (message
    # type -> message -> named columns; kartci.logs.tables), their fields measured on the wall
    # clock (kartci.logs.wallclock), and the command types an external stack may answer with
    # (message type -> the robot topic it is applied on; kartci.bridge)
    flatteners: Mapping[str, Flattener] = field(default_factory=dict)
    wall_clock: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    commands: Mapping[str, str] = field(default_factory=dict)
    # (FigureContext) -> the kind's figures of one scenario, in reading order (kartci.plotting)
    figures: Callable[..., Any] | None = None


@dataclass(frozen=True)
class WorldKind:
    """A world kind: its parameter model and the simulated world built from it."""

    name: str
    params: type[WorldParams]
    factory: Callable[..., Any]  # (params, dt_s) -> sim World; see kartci.sim.world
    description: str = ""


@dataclass(frozen=True)
class MetricSet:
    """Named metrics computed from a run log for one agent: `compute(context, params)`."""

    name: str
    defs: Mapping[str, MetricDef]
    compute: Callable[..., list[Metric]]  # (ScoreContext, params) -> metrics
    params: type[MetricParams] | None = None  # None: the set takes no parameters
    robots: tuple[str, ...] = ()  # robot kinds it applies to; empty: any
    description: str = ""


def lazy(target: str) -> Callable[..., Any]:
    """`module:attr`, imported on first call: a plugin's heavy imports (CasADi, PyBullet) wait
    until a scenario uses it."""
    module, _, attr = target.partition(":")

    def call(*args: Any, **kwargs: Any) -> Any:
        obj: Any = importlib.import_module(module)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj(*args, **kwargs)

    call.__qualname__ = target
    return call


T = TypeVar("T", Controller, Node, RobotKind, WorldKind, MetricSet)


@dataclass(frozen=True)
class BrokenPlugin:
    """A plugin that failed to load: reported once by its name, and only what names it fails
    (pluggy's way: the rest of the run goes on)."""

    name: str  # the entry point's name, or the project's plugin module
    where: str  # "entry point module:attr of dist 1.0, group kartci.controllers" or the config
    error: str  # "ValueError: boom": the plugin's own exception, one line
    trace: str = ""  # its traceback, written into the folder of each scenario that needs it

    @property
    def message(self) -> str:
        """One line: which plugin, from where, and its error."""
        return f"plugin '{self.name}' ({self.where}) failed to load: {self.error}"

    def failure(self) -> PluginError:
        """The error of a scenario that needs this plugin."""
        return PluginError(self.message, self.trace)


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """While a plugin's code is imported, whatever it prints goes to stderr, at Python's level
    (`print`) and the file descriptor's (a C extension, a child process): kartci's own stdout
    carries machine-readable output (`kartci schema > schema.json`, `kartci show`) that one
    chatty `import` must not corrupt."""
    sys.stdout.flush()
    try:
        saved: int | None = os.dup(1)
    except OSError:  # no stdout at all: nothing to protect
        saved = None
    try:
        if saved is not None:
            os.dup2(2, 1)
        with contextlib.redirect_stdout(sys.stderr):
            yield
    finally:
        sys.stderr.flush()
        if saved is not None:
            os.dup2(saved, 1)
            os.close(saved)


def plugin_failure(err: BaseException) -> bool:
    """Whether `err`, raised by a plugin's own code while it loads, is that plugin's failure:
    every exception, `SystemExit` (a module calling `sys.exit(0)` at import must not end kartci
    with a green exit and no output) and `GeneratorExit` included; only `KeyboardInterrupt` is
    not, since a real Ctrl-C landing during an import cannot be told from one a plugin raises,
    and Ctrl-C must always stop kartci (exit 130, never a green one)."""
    return not isinstance(err, KeyboardInterrupt)


def _broken(name: str, where: str, err: BaseException) -> BrokenPlugin:
    text = " ".join(str(err).split())
    return BrokenPlugin(name, where, f"{type(err).__name__}: {text}" if text else
                        type(err).__name__, "".join(traceback.format_exception(err)))


@dataclass
class Registry(Generic[T]):
    """Plugins of one kind by name; filled from entry points and project plugins on first use."""

    group: str  # entry-point group
    what: str  # for messages: "controller", "robot kind", ...
    kind: type[T]
    items: dict[str, T] = field(default_factory=dict)
    sources: dict[str, str] = field(default_factory=dict)  # name -> where it was registered
    broken: dict[str, BrokenPlugin] = field(default_factory=dict)  # entry points that failed

    def register(self, item: T, replace: bool = False, source: str = "") -> T:
        """Add one plugin; the same name twice is an error unless `replace`."""
        if not isinstance(item, self.kind):
            raise SpecError(f"{self.group}: {item!r} is not a kartci.plugins."
                            f"{self.kind.__name__}")
        old = self.items.get(item.name)
        if old is not None and old != item and not replace:
            raise SpecError(f"two different {self.what}s are registered as '{item.name}'")
        self.items[item.name] = item
        if source or item.name not in self.sources:
            self.sources[item.name] = source or _caller_module()
        return item

    def get(self, name: str) -> T:
        """The plugin of that name; a PluginError when it (or a project plugin module, which
        might have registered it) failed to load, a SpecError naming the known ones otherwise.
        Only the entry points of that name are imported when they provide it (see
        `_load_named`); anything else loads every plugin first, as `load` does."""
        if not _load_named(self, name):
            load()
        item = self.items.get(name)
        if item is not None:
            return item
        if name in self.broken:
            raise self.broken[name].failure()
        module = next(iter(_BROKEN_MODULES.values()), None)
        if module is not None:  # a project module that failed may be the one registering it
            raise PluginError(f"unknown {self.what} '{name}'; {module.message}", module.trace)
        raise SpecError(f"unknown {self.what} '{name}'{did_you_mean(name, self.items)}")

    def names(self) -> list[str]:
        """Every registered name, sorted."""
        load()
        return sorted(self.items)

    def all(self) -> list[T]:
        """Every registered plugin, by name."""
        load()
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
            reg.register(item, source=_caller_module())
            return
    raise SpecError(f"cannot register {item!r}: not a Controller, Node, RobotKind, WorldKind "
                    "or MetricSet")


def _caller_module() -> str:
    """The module that called into this one (for `kartci plugins`: where a plugin came from)."""
    frame = sys._getframe(1)
    while frame is not None and frame.f_globals.get("__name__") == __name__:
        frame = frame.f_back  # type: ignore[assignment]
    return str(frame.f_globals.get("__name__", "?")) if frame is not None else "?"


def _entry_point_source(ep: Any) -> str:
    where = _distribution(ep)
    return f"{ep.module} (entry point{where})" if where else ep.module


def _distribution(ep: Any) -> str:
    """' of dist 1.0' for an entry point that knows its distribution."""
    dist = getattr(ep, "dist", None)
    return f" of {dist.name} {dist.version}" if dist is not None else ""


@dataclass(frozen=True)
class PluginInfo:
    """One registered plugin, as `kartci plugins` lists it."""

    kind: str  # "controller", "node", "robot kind", "world kind", "metric set"
    name: str
    description: str
    source: str  # the module that registered it (and the distribution, for entry points)


def catalogue(project: Project | None = None) -> list[PluginInfo]:
    """Every registered plugin of every kind, installed ones and the project's own."""
    load(project)
    found = [PluginInfo(reg.what, name, item.description, reg.sources.get(name, "?"))
             for reg in REGISTRIES for name, item in sorted(reg.items.items())]
    found += [PluginInfo(reg.what, name, f"FAILED TO LOAD: {b.error}", b.where)
              for reg in REGISTRIES for name, b in sorted(reg.broken.items())]
    return found + [PluginInfo("plugin module", b.name, f"FAILED TO LOAD: {b.error}", b.where)
                    for b in _BROKEN_MODULES.values()]


def broken() -> list[BrokenPlugin]:
    """Every plugin that failed to load (all are loaded first), entry points then project
    modules: what a command reports once before running what does not need them."""
    load()
    return [*(b for reg in REGISTRIES for _, b in sorted(reg.broken.items())),
            *_BROKEN_MODULES.values()]


_LOADED: set[str] = set()  # "entry points" and the roots whose project plugins are imported
_BROKEN_MODULES: dict[str, BrokenPlugin] = {}  # project plugin modules that failed, by module
_NAMED: set[tuple[str, str]] = set()  # (group, name): entry points imported by `_load_named`


@cache
def _installed(group: str) -> EntryPoints:
    """A group's installed entry points, read once (a read scans every distribution: ~10 ms)."""
    return entry_points(group=group)


def _load_named(reg: Registry[Any], name: str) -> bool:
    """Import only the entry points named `name` in `reg`'s group; True when that registered
    it. Start-up: importing every plugin costs ~0.2 s (the bridge's Zenoh, every robot kind)
    where a command names two or three. Only without project plugin modules: one of those
    may register or replace any name, so with them every plugin loads, in `load`'s order.
    A caller's own registry (a subset, a test's) is never filled from entry points."""
    if (all(reg is not r for r in REGISTRIES) or "entry points" in _LOADED
            or project_mod.current().plugins):
        return False
    if (reg.group, name) not in _NAMED:
        _NAMED.add((reg.group, name))
        for ep in sorted(_installed(reg.group).select(name=name), key=lambda e: e.name):
            _load_entry_point(reg, ep)
    return name in reg.items and name not in reg.broken


def load(project: Project | None = None) -> None:
    """Import every installed plugin (entry points) and the project's plugin modules, once.
    Worker processes call this with their parent's project before running anything. A plugin
    that fails (any exception, SystemExit too) is recorded in `broken()`, never raised here:
    only the scenarios that name it fail (`Registry.get`); `plugin_failure` says what counts.
    What the plugins print while they load goes to stderr (`stdout_to_stderr`)."""
    if "entry points" not in _LOADED:
        _LOADED.add("entry points")
        for reg in REGISTRIES:
            for ep in sorted(_installed(reg.group), key=lambda e: e.name):
                if (reg.group, ep.name) not in _NAMED:
                    _load_entry_point(reg, ep)
    proj = project or project_mod.current()
    key = str(proj.root)
    if key in _LOADED or not proj.plugins:
        return
    _LOADED.add(key)
    if str(proj.root) not in sys.path:  # plugin modules kept in the project folder
        sys.path.insert(0, str(proj.root))
    config = proj.config_file.name if proj.config_file is not None else "the project"
    with stdout_to_stderr():
        for module in proj.plugins:
            try:
                importlib.import_module(module)
            except BaseException as err:  # a team's module: its own error, named, not "internal"
                if not plugin_failure(err):
                    raise
                _BROKEN_MODULES[module] = _broken(module, f"plugin module of {config}", err)


def _load_entry_point(reg: Registry[Any], ep: Any) -> None:
    """Register one entry point's object; a failure is recorded under its name."""
    where = f"entry point {ep.value}{_distribution(ep)}, group {reg.group}"
    try:
        with stdout_to_stderr():
            item = ep.load()
        if getattr(item, "name", None) != ep.name:
            raise SpecError(f"entry point '{ep.name}' must name an object whose name is "
                            f"'{ep.name}'")
        reg.register(item, source=_entry_point_source(ep))
    except BaseException as err:  # a broken plugin takes down only the scenarios that name it
        if not plugin_failure(err):
            raise
        reg.broken[ep.name] = _broken(ep.name, where, err)


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
