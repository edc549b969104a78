"""A run you step yourself: `Session.reset()`, then `step()` until `done`, each step handing
back the messages published in it. `kartci.sim.simulate()` is one client of it; a user's own
loop (an RL environment, a test that pokes at the run half way) is another.

One `step()` is one physics step (`physics.dt_s`): the physics advance from step k to k + 1,
then the robots sense at k + 1 and every agent whose control tick falls on k + 1 runs. So every
message of a step is stamped with the step's sim time, and a control tick is simply a step on
which the agents' commands appear (step `period_s / dt_s` times to go one control period on).
`reset()` publishes the messages at t = 0: the recorded scenario, the world's description, the
static transforms, then the first sensing and control tick. `command(agent, topic, message)`
publishes a command between steps as that agent's controller would at the current step (how
`kartci.gym` applies an action).

Agents can be handed in as objects (`agents={"kart0": MyController()}`): such an object replaces
the scenario's controller of that agent. The log still records the scenario as written, and a
`/kartci/replaced_agents` message says which agents were driven by which object instead, so a
log never lies about what drove.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterable, Mapping
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any, cast

import numpy as np

from kartci import core, portable
from kartci.core import Agent, AgentContext
from kartci.errors import KartciError, SpecError, did_you_mean
from kartci.logs import SCENARIO_TOPIC, McapLogWriter, msg
from kartci.project import held
from kartci.scenario import Scenario
from kartci.scenario.models import Carry
from kartci.sim.messages import tf_message
from kartci.sim.robot import Put, Robot, RobotContext, SimWorld
from kartci.sim.urdf import robot_descriptions

REPLACED_TOPIC = "/kartci/replaced_agents"  # std_msgs/String, JSON {agent: "module.Class"}

Message = tuple[str, Any]  # (absolute topic, ROS 2 message)
Tap = Callable[[str, Any, int, bool], None]  # (topic, message, t_ns, latched)
# Taps every Session started in this context gets (`kartci run --live`, see kartci.live)
LIVE_TAPS: ContextVar[tuple[Tap, ...]] = ContextVar("kartci_live_taps", default=())


@dataclass(frozen=True)
class RunInfo:
    """Facts of a run as the loop saw them.

    Attributes:
        sim_time_s: Sim time at the last step, s.
        steps: Physics steps taken.
        messages: Messages published (and recorded, when there is a log).
        finished_course: True when every robot finished its course before the duration ran out.
    """

    sim_time_s: float
    steps: int
    messages: int
    finished_course: bool


@dataclass(frozen=True)
class StepResult:
    """What one `Session.reset()` or `Session.step()` did.

    Attributes:
        step: Index k of the physics step the run is now at (0 after `reset()`).
        t_ns: Sim time of that step, ns (`k * physics.dt_s`).
        messages: Every message published during the call, in publishing order, as
            (absolute topic, message). Each carries its own header stamp; all are stamped
            `t_ns` except events closed at the end of the run (a collision still going on is
            stamped with its start).
        done: True when the run is over (every robot finished, or the duration ran out); the
            robots' closing messages are then part of `messages`.
        finished_course: True when the run ended because every robot finished its course.
    """

    step: int
    t_ns: int
    messages: tuple[Message, ...]
    done: bool
    finished_course: bool = False

    @property
    def t_s(self) -> float:
        """Sim time of the step, s."""
        return self.t_ns * 1e-9


def describe(obj: object) -> str:
    """`module.Class` of an object, as recorded for an agent handed in as an object."""
    cls = type(obj)
    return f"{cls.__module__}.{cls.__qualname__}"


def check_agent(name: str, obj: object, dt_s: float) -> Agent:
    """An object handed in as an agent, checked against the `Agent` protocol (period_s, inputs,
    on_message, step) and the physics step; a clear SpecError otherwise."""
    what = f"agents['{name}'] ({describe(obj)})"
    needs = ("an agent needs period_s (s), inputs (topics), on_message(topic, message) and "
             "step(t_ns) -> [(topic, message)]; see kartci.Agent")
    missing = [m for m in ("period_s", "inputs", "on_message", "step") if not hasattr(obj, m)]
    if missing:
        raise SpecError(f"{what}: lacks {', '.join(missing)}; {needs}")
    for method in ("on_message", "step"):
        if not callable(getattr(obj, method)):
            raise SpecError(f"{what}: {method} is not callable; {needs}")
    period = getattr(obj, "period_s")  # noqa: B009  (the protocol's attribute, checked above)
    if isinstance(period, bool) or not isinstance(period, int | float) or not period > 0:
        raise SpecError(f"{what}: period_s must be a positive number of seconds, not "
                        f"{period!r}")
    ratio = period / dt_s
    if abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
        raise SpecError(f"{what}: period_s {period:g} s is not a whole multiple of "
                        f"physics.dt_s {dt_s:g} s")
    inputs = getattr(obj, "inputs")  # noqa: B009
    if isinstance(inputs, str) or not isinstance(inputs, tuple | list) or not all(
            isinstance(t, str) for t in inputs):
        raise SpecError(f"{what}: inputs must be a tuple of topic names, not {inputs!r}")
    return cast(Agent, obj)  # checked member by member above


def check_agents(scenario: Scenario, agents: Mapping[str, object] | None) -> dict[str, Agent]:
    """Agent objects by name, each checked and naming an agent of the scenario."""
    out: dict[str, Agent] = {}
    for name, obj in (agents or {}).items():
        if name not in scenario.agents:
            raise SpecError(f"agents: scenario {scenario.name} has no agent '{name}'"
                            f"{did_you_mean(name, scenario.agents)}")
        out[name] = check_agent(name, obj, scenario.physics.dt_s)
    return out


def make_world(scenario: Scenario) -> SimWorld:
    """The scenario's world alone, from the world registry (the caller closes it)."""
    world: SimWorld = core.WORLDS.get(scenario.world.kind).factory(scenario.world,
                                                                     scenario.physics.dt_s)
    return world


@dataclass(frozen=True)
class NodeRun:
    """One node of a robot in the loop: its agent and its period in physics steps."""

    name: str
    agent: Agent
    every: int


def build_nodes(scenario: Scenario) -> dict[str, list[NodeRun]]:
    """Each agent's nodes (`agents.<name>.nodes`), built from the node registry, in the order
    the scenario lists them; they run in the robot's namespace before its controller."""
    dt = scenario.physics.dt_s
    out: dict[str, list[NodeRun]] = {}
    for name, spec in scenario.agents.items():
        ctx = AgentContext(name, spec.model, tuple(n for n in scenario.agents if n != name),
                           project=scenario.project)
        runs = []
        for node, params in spec.nodes.items():
            agent = check_agent(f"{name}.nodes.{node}",
                                core.NODES.get(node).build(params, ctx), dt)
            runs.append(NodeRun(node, agent, max(1, round(agent.period_s / dt))))
        out[name] = runs
    return out


def build_world(scenario: Scenario, agents: Mapping[str, Agent] | None = None,
                run_dir: Path | None = None) -> SimWorld:
    """The scenario's world with its robots and their agents in it (the caller closes it).
    An agent in `agents` (checked, see `check_agents`) replaces that agent's controller;
    `run_dir` is where controllers may write their own files (None: nowhere)."""
    dt = scenario.physics.dt_s
    odom_every = round(1.0 / scenario.physics.odom_rate_hz / dt)
    rng = np.random.default_rng(scenario.seed)
    given = agents or {}
    world = make_world(scenario)
    try:
        for name, spec in scenario.agents.items():
            agent = given.get(name)
            if agent is None:
                ctx = AgentContext(name, spec.model,
                                   tuple(n for n in scenario.agents if n != name), run_dir,
                                   scenario.world, scenario.project)
                agent = core.CONTROLLERS.get(spec.controller.type).build(spec.controller, ctx)
            try:
                robot_kind = core.ROBOTS.get(spec.model.kind)
                world.robots.append(robot_kind.factory(
                    RobotContext(name, spec, world, agent, dt, odom_every, rng)))
            except BaseException:
                close_agents([agent])
                raise
    except BaseException:
        try:
            close_agents(r.agent for r in world.robots)
        finally:
            world.close()
        raise
    return world


def close_agents(agents: Iterable[object]) -> None:
    """Let agents that hold resources (an external program, a network session) release them:
    an agent's optional `close()` is called when its run ends, however it ends."""
    for agent in agents:
        closer = getattr(agent, "close", None)
        if callable(closer):
            closer()


class Bus:
    """Writes every message to the log (if any), hands it to the agents that read its topic and
    keeps it for the current step's result."""

    def __init__(self, log: McapLogWriter | None, robots: list[Robot],
                 nodes: Mapping[str, list[NodeRun]] | None = None) -> None:
        """Route messages to the log and to the robots' agents and nodes, by the topics they
        read."""
        self.log, self.count = log, 0
        self.taps: list[Tap] = []  # also sent here (the live view)
        self.pending: list[Message] = []
        # full topic -> the agents reading it, and the name each asked for it by
        self.readers: dict[str, list[tuple[Any, str]]] = {}
        for r in robots:
            for agent in (*(n.agent for n in (nodes or {}).get(r.name, ())), r.agent):
                for want in agent.inputs:
                    full = want if want.startswith("/") else f"/{r.name}/{want}"
                    self.readers.setdefault(full, []).append((agent, want))

    def put(self, topic: str, m: Any, t_ns: int, record: bool = True,
            latched: bool = False) -> None:
        """Publish one message (absolute topic) at sim time `t_ns`; `record=False`: only to
        its readers, and not at all when nothing reads it; `latched` for what is published
        once at the start (recorded transient-local)."""
        if not record and topic not in self.readers:
            return
        if self.log is not None and record:
            self.log.write(topic, m, t_ns, latched)
        for tap in self.taps if record else ():
            tap(topic, m, t_ns, latched)
        self.count += 1
        self.pending.append((topic, m))
        for agent, want in self.readers.get(topic, ()):
            agent.on_message(want, m)

    def putter(self, namespace: str) -> Put:
        """`put` for one robot: relative topics go under `/<namespace>/`."""
        full: dict[str, str] = {}  # topic as put -> absolute topic (made once per topic)

        def put(topic: str, message: Any, t_ns: int, record: bool = True) -> None:
            name = full.get(topic)
            if name is None:
                name = full[topic] = topic if topic.startswith("/") else f"/{namespace}/{topic}"
            self.put(name, message, t_ns, record)
        return put

    def take(self) -> tuple[Message, ...]:
        """The messages published since the last call."""
        if not self.pending:
            return ()  # most physics steps publish nothing
        out, self.pending = tuple(self.pending), []
        return out


class Session:
    """One run of a scenario, stepped by the caller.

    ```python
    with Session(load_scenario("line_straight"), log_path=Path("run.mcap")) as s:
        r = s.reset()
        while not r.done:
            r = s.step()
            for topic, m in r.messages: ...
    ```

    A Session runs once: `reset()` starts the run, `step()` advances it one physics step until
    `done`. `close()` (or leaving the `with` block) releases the simulator and writes the log:
    a run closed before it is done gets its robots' closing messages first, so the log is that
    of a shorter run; a run that raised (or a `with` block left by an exception) leaves no log
    behind. Exceptions from agents (your own controller's) propagate unchanged.

    Args:
        scenario: The validated scenario (see `kartci.load_scenario`).
        log_path: Where to write the MCAP log; None records nothing.
        agents: Agent objects by agent name, replacing those agents' controllers.
        taps: Called with every message as it is published (topic, message, t_ns, latched),
            after it is logged: the live view's server is one.
    """

    def __init__(self, scenario: Scenario, log_path: Path | None = None,
                 agents: Mapping[str, object] | None = None,
                 taps: tuple[Tap, ...] = ()) -> None:
        """Check the agent objects; nothing is built before `reset()`."""
        portable.warn_unpinned()
        self.scenario = scenario
        self.taps = taps or LIVE_TAPS.get()
        self.log_path = log_path
        self.agents = check_agents(scenario, agents)
        self.replaced = {name: describe(a) for name, a in self.agents.items()}
        self.dt_ns = round(scenario.physics.dt_s * 1e9)
        self.steps = round(scenario.duration_s * 1e9 / self.dt_ns)  # the last step index
        self.k = 0
        self.done = False
        self.finished_course = False
        self._world: SimWorld | None = None
        self._log: McapLogWriter | None = None
        self._bus: Bus | None = None
        self._puts: list[Put] = []
        self._lanes: list[tuple[Robot, Put, tuple[NodeRun, ...]]] = []  # each robot's round
        self._nodes: dict[str, list[NodeRun]] = {}
        self._carries: dict[str, Carry] = {}  # robots still to be carried, by name
        self._started = self._closed = self._failed = False

    @property
    def t_ns(self) -> int:
        """Sim time of the current step, ns."""
        return self.k * self.dt_ns

    @property
    def world(self) -> SimWorld:
        """The simulated world (its robots under `.robots`); only between reset and close."""
        if self._world is None:
            raise KartciError("Session: no world; call reset() first")
        return self._world

    def info(self) -> RunInfo:
        """Sim time, steps, message count and whether the course was finished, so far."""
        count = self._bus.count if self._bus is not None else 0
        return RunInfo(self.k * self.dt_ns * 1e-9, self.k, count, self.finished_course)

    def reset(self) -> StepResult:
        """Build the world, open the log and publish everything at t = 0: the recorded
        scenario, which agents were handed in as objects, the world's static messages, the
        robots' static transforms, and the first sensing and control tick."""
        if self._started:
            raise KartciError("Session.reset: this session has run; a Session runs once, "
                              "make a new one")
        self._started = True
        try:
            # plugins load from the scenario's project; every registry lookup asks for it
            with held(self.scenario.project):
                self._world = build_world(self.scenario, self.agents,
                                          self.log_path.parent if self.log_path else None)
                self._nodes = build_nodes(self.scenario)
            robots = self._world.robots
            self._carries = {r.name: c for r in robots
                             if (c := self.scenario.agents[r.name].carry) is not None}
            for r in robots:
                if r.name in self._carries and not (hasattr(r, "reinitialise")
                                                    and hasattr(r, "body")):
                    raise SpecError(f"agents.{r.name}.carry: a {type(r).__name__} cannot be "
                                    "re-placed mid-run (it has no reinitialise())")
            if self.log_path is not None:
                self._log = McapLogWriter(self.log_path)
            bus = self._bus = Bus(self._log, robots, self._nodes)
            self._puts = [bus.putter(r.name) for r in robots]
            self._lanes = [(r, put, tuple(self._nodes.get(r.name, ())))
                           for r, put in zip(robots, self._puts, strict=True)]
            bus.taps = list(self.taps)
            bus.put(SCENARIO_TOPIC, msg("std_msgs/msg/String",
                                        data=self.scenario.model_dump_json()), 0, latched=True)
            if self.replaced:
                bus.put(REPLACED_TOPIC, msg("std_msgs/msg/String",
                                            data=json.dumps(self.replaced, sort_keys=True)), 0,
                        latched=True)
            for topic, m in self._world.static_messages():
                bus.put(topic, m, 0, latched=True)
            for topic, m in robot_descriptions(self.scenario):
                bus.put(topic, m, 0, latched=True)
            bus.put("/tf_static", tf_message([t for r in robots
                                              for t in r.static_transforms()]), 0, latched=True)
            return self._tick()
        except BaseException:
            self._fail()
            raise

    def step(self) -> StepResult:
        """Advance one physics step (actuators, physics, contacts), then sense and, on a
        control tick, run the agents; returns the messages of that step."""
        if not self._started:
            raise KartciError("Session.step: call reset() first")
        if self._closed:
            raise KartciError("Session.step: the session is closed")
        if self.done:
            raise KartciError(f"Session.step: the run is over (at step {self.k}, "
                              f"t={self.t_ns * 1e-9:g} s)")
        try:
            self._advance()
            return self._tick()
        except BaseException:
            self._fail()
            raise

    def _advance(self) -> None:
        """Actuators, one physics step, contacts; the step count moves on."""
        world, k = self._world, self.k
        assert world is not None  # step() checked that the run started
        for r in world.robots:
            r.pre_step(k)
        world.step()
        t_next = (k + 1) * self.dt_ns
        for r, put, _ in self._lanes:
            r.post_step(t_next, put)
        self.k = k + 1

    def run_to_end(self, on_progress: Callable[[float], None] | None) -> None:
        """`step()` until the run is over, for `simulate()`, which reads no step's result:
        none is made and the messages are not kept. `on_progress` gets the sim time reached,
        s, after every step."""
        bus = self._bus
        assert bus is not None  # reset() made it
        try:
            while not self.done:
                self._advance()
                self._sense_and_control()
                bus.pending.clear()
                if on_progress is not None:
                    on_progress(self.k * self.dt_ns * 1e-9)
        except BaseException:
            self._fail()
            raise

    def command(self, agent: str, topic: str, message: Any) -> None:
        """Publish a command for `agent`'s robot at the current step, as its controller would
        on a control tick: recorded, handed to the topic's readers, applied to the robot. For a
        caller that decides between steps (a Gymnasium env's action, see kartci.gym)."""
        if not self._started or self._closed or self.done:
            raise KartciError("Session.command: only between reset() and the end of the run")
        names = [r.name for r in self.world.robots]
        if agent not in names:
            raise SpecError(f"Session.command: no agent '{agent}'{did_you_mean(agent, names)}")
        i = names.index(agent)
        self._puts[i](topic, message, self.t_ns)
        self.world.robots[i].apply(topic, message)

    def _tick(self) -> StepResult:
        """Sense and control at the current step; ends the run when it is over."""
        self._sense_and_control()
        assert self._bus is not None
        return StepResult(self.k, self.k * self.dt_ns, self._bus.take(), self.done,
                          self.finished_course)

    def _sense_and_control(self) -> None:
        """`_tick` without its result: `simulate()` steps on this, reading nothing back."""
        k = self.k
        t_ns = k * self.dt_ns
        for r, put, nodes in self._lanes:
            if self._carries:
                self._carry(r, t_ns)
            r.sense(k, t_ns, put)
            for node in nodes:
                if k % node.every == 0:
                    for topic, m in node.agent.step(t_ns):
                        put(topic, m, t_ns)
            if k % r.ctrl_every == 0:
                for topic, m in r.agent.step(t_ns):
                    put(topic, m, t_ns)
                    r.apply(topic, m)
        self._end_if_over(k)

    def _end_if_over(self, k: int) -> None:
        """The run is over when every robot has finished its course, or at the last step."""
        for r, _, _ in self._lanes:
            if not r.done(k):  # a robot still on its course: over when the time is up
                if k == self.steps:
                    self.done = True
                break
        else:
            self.finished_course = self.done = True
        if self.done:
            self._finish()

    def _carry(self, r: Robot, t_ns: int) -> None:
        """Carry a robot whose `carry` time has come: its pose jumps, its speed and yaw rate are
        kept; its sensors and agents are not told."""
        c = self._carries.get(r.name)
        if c is None or t_ns < round(c.at_s * 1e9):
            return
        del self._carries[r.name]
        st = r.body.state()  # type: ignore[attr-defined]  # checked in reset()
        x, y, _ = st.xyz
        r.reinitialise(x + c.offset_m[0], y + c.offset_m[1],  # type: ignore[attr-defined]
                       st.yaw + c.yaw_rad, st.v_body[0], st.w_body[2])

    def _finish(self) -> None:
        for r, put in zip(self.world.robots, self._puts, strict=True):
            r.finish(put)

    def _fail(self) -> None:
        self._failed = True
        self.close()

    def close(self) -> None:
        """Release the simulator and write the log (none if the run raised). Idempotent."""
        if self._closed:
            return
        self._closed = True
        try:
            if self._log is not None:
                ok = not self._failed
                try:
                    if ok and not self.done and self._world is not None:
                        self._finish()  # events still open go into the shorter run's log
                except BaseException:
                    ok = False
                    raise
                finally:
                    self._log.close(ok=ok)
        finally:
            if self._world is not None:
                try:
                    close_agents(r.agent for r in self._world.robots)
                finally:
                    self._world.close()
                    self._world = None

    def __enter__(self) -> Session:
        """The session itself; leaving the block closes it."""
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        """Close; an exception in the block discards the log."""
        if exc_type is not None:
            self._failed = True
        self.close()

    def __del__(self) -> None:
        """A Session dropped without close(): free the simulator, keep no partial log."""
        if not getattr(self, "_closed", True):
            self._failed = True
            with contextlib.suppress(Exception):  # nothing to report to at shutdown
                self.close()

