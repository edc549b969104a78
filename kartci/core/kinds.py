"""The contracts of what a team plugs in: controller and node types, robot kinds, world kinds
and metric sets, each a frozen value naming its parameter model and its functions. Every
function a kind hands kartci has a `Protocol` here, so strict mypy checks a plugin against the
signature kartci calls it with (a `lazy("module:attr")` target is checked where it is defined,
against the same Protocol, by annotating it). The registry that names them is
`kartci.core.registry`; loading plugins is `kartci.core.loading`."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar, Generic, Protocol, TypeVar

from kartci.core.agent import Agent
from kartci.core.control import ControlSpace
from kartci.core.course import Course
from kartci.core.faults import Fault
from kartci.core.metric import Metric, MetricDef
from kartci.core.params import (
    ControllerParams,
    Frozen,
    MetricParams,
    NodeParams,
    RobotParams,
    WorldParams,
)
from kartci.errors import SpecError

if TYPE_CHECKING:  # the types the Protocols name, from the packages that call them
    from kartci.metrics import ScoreContext
    from kartci.plotting import Figure, FigureContext, PlotContext, Plots
    from kartci.sim.robot import Robot, RobotContext, SimWorld


class DataFolders(Protocol):
    """What a controller or node may ask of the project it runs in (`kartci.project.Project`
    is one, handed in by the entry point, never looked up here): where its data files are."""

    @property
    def root(self) -> Path:
        """The project's folder (an external stack's working folder)."""
        ...

    @property
    def model_path(self) -> tuple[Path, ...]:
        """Robot model folders in search order (the project's own, then kartci's)."""
        ...

    @property
    def world_path(self) -> tuple[Path, ...]:
        """World folders in search order (the project's own, then kartci's)."""
        ...


@dataclass(frozen=True)
class AgentContext:
    """What a controller is told when it is built: who it is and which robot it drives.
    Everything else it learns from messages."""

    name: str
    model: RobotParams
    others: tuple[str, ...] = ()  # the other agents of the scenario (their topics: /<name>/...)
    run_dir: Path | None = None  # where the run's files go (a controller's own output files)
    world: WorldParams | None = None  # the scenario's world: the map a real robot would carry
    # the project the scenario was loaded in (None: a scenario built by hand; kartci's own
    # data folders only): where a controller finds a data file named in its parameters
    project: DataFolders | None = None


P = TypeVar("P", ControllerParams, NodeParams)


@dataclass(frozen=True)
class _AgentType(Generic[P]):
    """What controllers and nodes share: a parameter model, a factory
    `(params, context) -> Agent` and the robot kinds it works with (empty: any)."""

    name: str
    params: type[P]
    factory: AgentFactory
    robots: tuple[str, ...] = ()
    description: str = ""
    # instead of naming kinds: it works with every registered kind this is true of (a kind-
    # neutral agent states what it needs of a robot: the topics it reads, its wheel odometry)
    fits: Callable[[RobotKind], bool] | None = None
    faults: tuple[Fault, ...] = ()  # faults of its own parameters (`kartci faults`)
    works_on: ClassVar[str] = "works with"  # the verb of the wrong-robot error

    def kinds(self, robots: Iterable[RobotKind] | None = None) -> tuple[str, ...]:
        """The robot kinds it works with among `robots` (default: every registered one);
        empty and no `fits`: any."""
        if self.fits is None:
            return self.robots
        if robots is None:
            # the contracts sit below the registry that holds the process-wide kinds
            from kartci.core.registry import ROBOTS

            robots = ROBOTS.all()
        return tuple(k.name for k in robots if self.fits(k))

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

    fit: FitModel | None = None  # fits its own prediction model to a log
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


# A kind's functions take its own parameter model (a subclass of RobotParams, WorldParams or
# MetricParams): typed `Any` below, since a function of the subclass is not one of the base.


class AgentFactory(Protocol):
    """A controller or node type's factory."""

    def __call__(self, params: Any, ctx: AgentContext, /) -> Agent:
        """`(params, context) -> Agent`: a controller or node for one robot."""
        ...


class FitModel(Protocol):
    """A controller's model fit (`Controller.fit`)."""

    def __call__(self, log: Path, names: list[str], out: Path, /) -> list[str]:
        """`(run log, parameter names, output folder) -> lines to show`: fits a controller's own
        prediction model to a log and writes the result there (`kartci calibrate --mpcc`)."""
        ...


class WarningsFn(Protocol):
    """A robot kind's warnings about one agent of a scenario (`RobotKind.warnings`)."""

    def __call__(self, model: RobotParams, controller: object, world: object, /) -> list[str]:
        """`(the robot's parameters, its controller's, the world's) -> warnings`: what would
        make a run misleading though valid (a speed the robot's model cannot keep stable), one
        line each; the caller names the scenario and the agent."""
        ...


class RobotFactory(Protocol):
    """A robot kind's factory."""

    def __call__(self, ctx: RobotContext, /) -> Robot:
        """`(RobotContext) -> Robot`: the simulated robot (kartci.sim.robot)."""
        ...


class PlotsFn(Protocol):
    """A robot kind's plot data (`RobotKind.plots`)."""

    def __call__(self, ctx: PlotContext, /) -> Plots:
        """`(PlotContext) -> Plots`: what a run's figures draw, read back from its log."""
        ...


class FiguresFn(Protocol):
    """A robot kind's figures (`RobotKind.figures`)."""

    def __call__(self, ctx: FigureContext, /) -> list[Figure]:
        """`(FigureContext) -> [Figure]`: the kind's figures of one scenario, in reading order."""
        ...


class OutlineFn(Protocol):
    """A robot kind's outline (`RobotKind.outline`)."""

    def __call__(self, model: Any, urdf: str | None, /) -> Outline:
        """`(model, its URDF text as a log recorded it, or None: the model's file) -> Outline`."""
        ...


class OdometryFn(Protocol):
    """A robot kind's wheel odometry (`RobotKind.odometry`)."""

    def __call__(self, model: Any, /) -> WheelOdometry:
        """`(model) -> WheelOdometry`."""
        ...


class JoyCommand(Protocol):
    """A joystick mapping of a robot."""

    def __call__(self, joy: Any, frame: str, /) -> tuple[str, Any]:
        """`(sensor_msgs/Joy, frame to stamp with) -> (topic, message)` that commands the robot."""
        ...


class JoystickFn(Protocol):
    """A robot kind's joystick mappings (`RobotKind.joystick`)."""

    def __call__(self, model: Any, mapping: str, models: tuple[Path, ...], /) -> JoyCommand:
        """`(model, mapping name, robot model folders a name is looked up in) ->
        JoyCommand`."""
        ...


class ReplayFn(Protocol):
    """A robot kind's replay of recorded input (`RobotKind.replay`)."""

    def __call__(self, log: Path, topic: str, msgtype: str, mapping: str,
                 models: tuple[Path, ...], /) -> ControllerParams:
        """`(log, topic, message type, joystick mapping, robot model folders a mapping name is
        looked up in) -> ControllerParams` that replay that recorded input into a robot of this
        kind (`kartci replay`); checks the log first."""
        ...


class ControlFn(Protocol):
    """A robot kind's control space (`RobotKind.control`)."""

    def __call__(self, model: Any, /) -> ControlSpace:
        """`(model) -> ControlSpace`: its command and observation as vectors (kartci.gym)."""
        ...


class WorldFactory(Protocol):
    """A world kind's factory."""

    def __call__(self, params: Any, dt_s: float, /) -> SimWorld:
        """`(params, physics step s) -> SimWorld`: the simulated world (kartci.sim.world)."""
        ...


class CourseFn(Protocol):
    """A world kind's course (`WorldKind.course`)."""

    def __call__(self, params: Any, /) -> Course:
        """`(params) -> Course`: the course robots follow, read from the world's parameters
        without a simulator (kartci.gym's course-relative observation)."""
        ...


class ComputeFn(Protocol):
    """A metric set's computation (`MetricSet.compute`)."""

    def __call__(self, ctx: ScoreContext, params: Any, /) -> list[Metric]:
        """`(ScoreContext, params) -> [Metric]`: a metric set's metrics for one agent."""
        ...


@dataclass(frozen=True)
class RobotKind:
    """A robot kind: its parameter model, the simulated robot, its metric sets and plots, and
    what kind-neutral code (nodes, the bridge, real-log import, the CLI) asks of it instead of
    naming it."""

    name: str
    params: type[RobotParams]
    factory: RobotFactory
    metrics: tuple[str, ...] = ()  # metric sets computed for every agent of this kind
    plots: PlotsFn | None = None
    description: str = ""
    sensors: type[Frozen] | None = None  # the robot's sensor specs (agents.<name>.sensors)
    # the robot seen from above in base_link, m: what clearance, detection ground truth and
    # other robots' lidar see of a robot of this kind (None: a point at base_link)
    outline: OutlineFn | None = None
    publishes: tuple[str, ...] = ()  # topics its sensors can publish in its namespace (`imu`)
    accepts: tuple[str, ...] = ()  # command topics it applies (`cmd_vel`, `wheel_cmd`)
    odometry: OdometryFn | None = None
    joystick: JoystickFn | None = None
    replay: ReplayFn | None = None
    simreal: SimReal | None = None
    control: ControlFn | None = None  # for a learning loop (kartci.gym)
    # what only this kind knows of its own messages: how a log's tables flatten them (message
    # type -> message -> named columns; kartci.logs.tables), their fields measured on the wall
    # clock (kartci.logs.wallclock), and the command types an external stack may answer with
    # (message type -> the robot topic it is applied on; kartci.bridge)
    flatteners: Mapping[str, Flattener] = field(default_factory=dict)
    wall_clock: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    commands: Mapping[str, str] = field(default_factory=dict)
    figures: FiguresFn | None = None  # None: the kind-neutral figures (kartci.plotting)
    # faults of its model and sensors (`model.KEY`, `sensors.KEY`) that `kartci faults` injects
    faults: tuple[Fault, ...] = ()
    warnings: WarningsFn | None = None  # what it warns of an agent before a run


@dataclass(frozen=True)
class WorldKind:
    """A world kind: its parameter model and the simulated world built from it."""

    name: str
    params: type[WorldParams]
    factory: WorldFactory
    description: str = ""
    course: CourseFn | None = None  # the course robots follow; None: the world has none
    faults: tuple[Fault, ...] = ()  # faults of its parameters (`kartci faults`)


@dataclass(frozen=True)
class MetricSet:
    """Named metrics computed from a run log for one agent: `compute(context, params)`."""

    name: str
    defs: Mapping[str, MetricDef]
    compute: ComputeFn
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
