"""`controller: {type: external}`: the robot's sensors and `/clock` go out over Zenoh, the stack's
commands come back and are published into the loop like an in-process agent's outbox (so they
are recorded and applied as usual).

Lockstep (the default, `kartci.bridge.lockstep`): at every control tick the bridge publishes the
tick's sensor messages, waits until the stack's own topics that answer data have published for
the tick, then publishes `/clock` and waits until the topics that answer time and every command
topic have (a stamped command must carry the tick's stamp; an unstamped one is matched by count;
earlier ones are stale and dropped). t = 0 waits for the stack's graph to be complete and
settled. A tick whose answer misses `tick_timeout_s` of wall clock is a `late_commands` event
(the last command holds); `max_late_in_row` of them in a row, the stack's exit, or its absence at
startup end the run as an error naming the program's last output.

The stack kartci starts is told (rmw_zenoh's $ZENOH_CONFIG_OVERRIDE) to be a Zenoh client of
kartci's session: every message between its nodes then passes through kartci, in one ordered
link per node, so kartci sees each one and a node gets a tick's data from the others before the
tick's `/clock`.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from kartci.atomic import write_text_atomic
from kartci.bridge import ros2
from kartci.bridge.attach import announce, for_zenoh
from kartci.bridge.child import Child
from kartci.bridge.link import Inbox, Node, Publisher, open_listening, routed
from kartci.bridge.lockstep import (
    ARRIVALS,
    LEARN_QUIET_S,
    Endpoint,
    Expect,
    Kind,
    Ledger,
    Phase,
    mismatches,
    offer_for,
    plan,
    unpublished,
)
from kartci.bridge.params import ExternalController, Mode, command_types
from kartci.core import ROBOTS, AgentContext, JoyCommand, Outbox, RobotParams
from kartci.errors import RunError, SpecError
from kartci.logs.types import base_link, msg, stamp_ns
from kartci.project import BUILTIN_MODELS

CLOCK = "rosgraph_msgs/msg/Clock"
LATE_TOPIC = "bridge/late_commands"  # std_msgs/UInt32: the count so far, at each late tick


def child_env(endpoint: str, domain_id: int, namespace: str) -> dict[str, str]:
    """What the stack is told: the endpoint to connect to (kartci's variable, and Zenoh's
    override for rmw_zenoh nodes: a client of kartci's session, so kartci routes every message
    between them; no router check), the domain, the namespace."""
    override = (f'mode="client";connect/endpoints=["{endpoint}"];'
                'scouting/multicast/enabled=false')
    return {"KARTCI_ZENOH_ENDPOINT": endpoint, "ZENOH_CONFIG_OVERRIDE": override,
            "ZENOH_ROUTER_CHECK_ATTEMPTS": "-1", "ROS_DOMAIN_ID": str(domain_id),
            "KARTCI_NAMESPACE": namespace}


def substitute(text: str, values: dict[str, str]) -> str:
    """`{name}` placeholders replaced; any other brace (JSON in an argument) left alone."""
    for key, value in values.items():
        text = text.replace(f"{{{key}}}", value)
    return text


def joystick(agent: str, model: RobotParams, mapping: str, models: tuple[Path, ...]
             ) -> JoyCommand:
    """What the robot's kind makes of the stack's Joy messages through `mapping` (a name looked
    up in the robot model folders `models`)."""
    make = ROBOTS.get(model.kind).joystick
    if make is None:
        raise SpecError(f"agent {agent}: a {model.kind} robot reads no joystick; command it "
                        "with another of the external controller's command types")
    return make(model, mapping, models)


class ExternalAgent:
    """The bridge for one agent: a Zenoh node, the stack's process, the lockstep."""

    inputs: tuple[str, ...]
    _pending: list[tuple[str, Any]]
    _wall0: float | None
    _latest: dict[str, Any]
    child: Child | None
    ledger: Ledger | None

    def __init__(self, spec: ExternalController, ctx: AgentContext) -> None:
        self._lockstep_state(spec, ctx)
        self._pubs: dict[tuple[str, str], Publisher] = {}
        self._tokens: set[str] = set()
        self._tokens_changed = time.perf_counter()
        session, self.endpoint = open_listening(
            spec.port, connect=spec.connect, router=spec.zenoh_mode == "router",
            allow_remote=spec.allow_remote)
        self.node = Node(session, spec.domain_id, spec.node_name, spec.ros_distro)
        try:
            self.clock = self.node.publisher("/clock", CLOCK)
            announce(ctx.run_dir, self.name, for_zenoh(  # run.json + terminal
                child_env(self.endpoint, spec.domain_id, self.name), self.endpoint,
                [*self.commands, "/clock"][0]))
            for topic, typename in self.commands.items():
                self.node.subscription(topic, typename, self._pusher(topic))
            self.node.watch_tokens(self._token)
            if spec.command:
                self.child = self._start(ctx.run_dir)
        except BaseException:
            self.close()
            raise

    def _lockstep_state(self, spec: ExternalController, ctx: AgentContext) -> None:
        """What the lockstep needs whatever the middleware (the DDS agent sets it too)."""
        self.spec, self.name, self.period_s = spec, ctx.name, spec.period_s
        self.inputs = tuple(spec.publish)
        self.frame = base_link(ctx.name)
        # the project's folder ({root} in the stack's command; a scenario built by hand: the
        # working directory) and its model folders (a joystick mapping's name)
        self.root = ctx.project.root if ctx.project is not None else Path.cwd()
        models = ctx.project.model_path if ctx.project is not None else (BUILTIN_MODELS,)
        self.joystick = joystick(ctx.name, ctx.model, spec.mapping, models) if any(
            c.type == "sensor_msgs/msg/Joy" for c in spec.commands) else None
        self.commands = {self._full(c.topic): c.type for c in spec.commands}
        self.applied_on = command_types()  # command type -> the robot topic it is applied on
        self.stamped = self._stamped()
        self.late = self._late_in_row = 0
        self._pending = []
        self._ready = False
        self._wall0 = None
        self._latest = {}
        self._got: dict[str, Any] = {}
        self._routers: set[int] = set()
        self._arrived: list[str] = []  # this tick's stack messages, in arrival order
        self._arrivals: list[str] = []  # one line per tick: t_ns and its messages' topics
        self.run_dir = ctx.run_dir
        self.child = None
        self.ledger = None
        self.inbox = Inbox()

    def _token(self, key: str) -> None:
        self._tokens.add(key)
        self._tokens_changed = time.perf_counter()

    def _pusher(self, topic: str) -> Callable[[bytes], None]:
        def push(payload: bytes) -> None:
            self.inbox.push(topic, payload)
        return push

    def _full(self, topic: str) -> str:
        return topic if topic.startswith("/") else f"/{self.name}/{topic}"

    def _start(self, run_dir: Path | None) -> Child:
        root = self.root
        values = {"python": sys.executable, "endpoint": self.endpoint, "root": str(root),
                  "domain_id": str(self.spec.domain_id), "namespace": self.name}
        argv = [substitute(a, values) for a in self.spec.command]
        cwd = root / self.spec.cwd if self.spec.cwd else root
        out = run_dir or Path(tempfile.mkdtemp(prefix="kartci-external-"))
        env = {**child_env(self.endpoint, self.spec.domain_id, self.name),
               **{k: substitute(v, values) for k, v in self.spec.env.items()}}
        return Child(argv, cwd, env, out, f"{self.name}.external")

    def on_message(self, topic: str, message: Any) -> None:
        """Queue a sensor message for the next tick's publication."""
        self._pending.append((self._full(topic), message))

    def step(self, t_ns: int) -> Outbox:
        """Publish the tick's sensors, wait for what answers them, publish /clock, wait for
        what answers it (in lockstep; paced: publish both and take the latest commands)."""
        if not self._ready:
            self._wait_ready()
        if self.spec.mode is Mode.PACED:
            self._pace(t_ns)
            self._publish_sensors(t_ns)
            self._publish_clock(t_ns)
            self._receive(self.inbox.take(), None)
            return self._outbox(self._latest)
        assert self.ledger is not None
        learning = self.ledger.learning()
        first = list(self._pending) if self.ledger.tick == 0 else None
        deadline = time.perf_counter() + self.spec.tick_timeout_s + (
            2 * LEARN_QUIET_S if learning else 0.0)
        self._got = {}
        self._publish_sensors(t_ns)
        on_time = self._phase(Phase.SENSORS, t_ns, deadline, learning)
        if self.ledger.awaits(Phase.SENSORS):
            self._hand_off()
        self._publish_clock(t_ns)
        on_time = on_time and self._phase(Phase.CLOCK, t_ns, deadline, learning)
        if not on_time and first is not None and self._restartable():
            self._restart(first)
            return self.step(t_ns)
        if learning:
            self._learnt()
        self._arrivals.append(" ".join([str(t_ns), *self._arrived]))
        self._arrived = []
        if not on_time:
            self._count_late(t_ns)  # names what is missing before the ledger moves on
        self.ledger.next_tick(stamped=self.stamped)
        if not on_time:
            return [(LATE_TOPIC, msg("std_msgs/msg/UInt32", data=self.late))]
        self._late_in_row = 0
        return self._outbox(self._got)

    def _restartable(self) -> bool:
        """Whether a first tick without an answer starts the stack again: never over Zenoh,
        where every link between the stack's nodes passes through kartci's session, so the
        start barrier sees them all (the DDS agent says otherwise)."""
        return False

    def _restart(self, first: list[tuple[str, Any]]) -> None:
        """Start the stack again and make tick 0 new, its sensor messages `first` pending
        again (the DDS agent's)."""
        raise NotImplementedError

    def _stamped(self) -> frozenset[str]:
        """Command topics whose type has a header: matched to ticks by stamp."""
        fields = ros2.typestore(self.spec.ros_distro).fielddefs
        return frozenset(t for t, ty in self.commands.items()
                         if any(name == "header" for name, _ in fields[ty][1]))

    def _learnt(self) -> None:
        """Tick 0 is over: say what every tick waits for (a team pins it with waits_for)."""
        assert self.ledger is not None
        if self.ledger.waits_for() and len(self.ledger.expect) > len(self.commands):
            print(f"{self.name}: lockstep waits for "
                  + ", ".join(f"{w['topic']} after {w['after']}"
                              for w in self.ledger.waits_for()), file=sys.stderr)

    def _phase(self, phase: Phase, t_ns: int, deadline: float, learning: bool) -> bool:
        """Wait until every topic of `phase` has published for this tick; False when the
        deadline passed first. Learning (tick 0), a topic that may answer this phase but has
        not published `LEARN_QUIET_S` after the last message does not answer it."""
        assert self.ledger is not None
        quiet_since = time.perf_counter()
        while True:
            items = self.inbox.take()
            now = time.perf_counter()
            if items:
                quiet_since = now
                self._receive(items, t_ns)
            if not self.ledger.missing(phase, learnt_only=learning
                                       and now - quiet_since >= LEARN_QUIET_S):
                break
            left = deadline - now
            if left <= 0:
                return False
            if not self.inbox.wait(min(left, 0.05)):
                self._check_alive(t_ns)
        if learning:
            self.ledger.learn(phase)
        return True

    def _receive(self, items: list[tuple[str, bytes | None]],
                 t_ns: int | None) -> dict[str, Any]:
        """Count and decode what arrived; in lockstep (`t_ns` given) keep as this tick's
        answer only a command of this tick (its stamp, or its count), drop earlier ones, and
        stop at a topic that published more than it was due. The answers among `items`."""
        got: dict[str, Any] = {}
        for topic, payload in items:
            if t_ns is not None:
                self._arrived.append(topic)
            if payload is None or topic not in self.commands:  # the stack's own topic, counted
                self._count(topic, t_ns)
                continue
            typename = self.commands[topic]
            try:
                m = ros2.deserialize(payload, typename, self.spec.ros_distro)
            except Exception as err:  # a malformed payload is the stack's error, named
                raise RunError(f"external controller of {self.name}: a {typename} on {topic} "
                               f"does not decode ({type(err).__name__}: {err})") from err
            self._latest[topic] = m
            if t_ns is None:
                continue
            if topic in self.stamped:
                if stamp_ns(m.header) != t_ns:
                    continue  # stale: an earlier tick's answer
                if topic not in self._got:
                    self._count(topic, t_ns)
                got[topic] = self._got[topic] = m
            elif self._count(topic, t_ns) == 0:
                got[topic] = self._got[topic] = m
        return got

    def _count(self, topic: str, t_ns: int | None) -> int:
        """Count one message into the ledger: -1 stale, 0 this tick's; beyond is an error."""
        if self.ledger is None or t_ns is None or topic not in self.ledger.expect:
            return 0
        where = self.ledger.belongs(topic, self.ledger.count(topic))
        if where > 0:
            e = self.ledger.expect[topic]
            raise RunError(
                f"external controller of {self.name}: {topic} published more than the "
                f"{e.count} message(s) due in the tick at t={t_ns * 1e-9:.3f} s; if a node "
                f"publishes it more often, say so in the scenario: waits_for: [{{topic: "
                f"{topic}, count: N}}] (or count: 0 not to wait for it)")
        return where

    def _declare(self) -> None:
        """A publisher for each new (topic, type) of the pending messages, offering what the
        stack's subscriptions to it ask; before its first put, it waits until the stack's
        subscriptions (if its tokens show any) have matched."""
        new = []
        stack = self._stack_endpoints()
        for topic, m in self._pending:
            typename = type(m).__msgtype__
            if (topic, typename) not in self._pubs:
                offer = offer_for(e.qos for e in stack if e.kind is Kind.SUBSCRIPTION
                                  and e.topic == topic and e.typename == typename)
                self._pubs[(topic, typename)] = pub = self.node.publisher(topic, typename,
                                                                          offer)
                new.append((topic, typename, pub))
        if not new:
            return
        subscribed = {(e.topic, e.typename) for e in stack if e.kind is Kind.SUBSCRIPTION}
        deadline = time.perf_counter() + self.spec.startup_timeout_s
        for topic, typename, pub in new:
            while (topic, typename) in subscribed and not pub.matched():
                if time.perf_counter() > deadline:
                    raise RunError(f"external controller of {self.name}: the stack's "
                                   f"subscription to {topic} never matched; {self._output()}")
                time.sleep(0.001)

    def _stack_endpoints(self) -> list[Endpoint]:
        """Every publisher and subscription of the stack (not kartci's own) its tokens show,
        with kartci's type names (token fields 2, 5, 7-12: session, kind, namespace, node,
        mangled topic, DDS type name, hash, QoS)."""
        own = str(self.node.session.zid())
        kinds = {"MP": Kind.PUBLISHER, "MS": Kind.SUBSCRIPTION}
        out = []
        for p in (k.split("/") for k in list(self._tokens)):
            if len(p) != 13 or p[2] == own or p[5] not in kinds:
                continue
            namespace = p[7].replace("%", "/") if p[7] != "%" else ""
            out.append(Endpoint(f"{namespace}/{p[8]}", kinds[p[5]], p[9].replace("%", "/"),
                                ros2.ros_type_name(p[10]), ros2.parse_qos(p[12])))
        return out

    def _publish_sensors(self, t_ns: int) -> None:
        self._declare()
        distro = self.spec.ros_distro
        for topic, m in self._pending:
            self._pubs[(topic, type(m).__msgtype__)].put(ros2.serialize(m, distro))
        self._pending.clear()

    def _publish_clock(self, t_ns: int) -> None:
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        self.clock.put(ros2.serialize(msg(CLOCK, clock=msg(
            "builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)), self.spec.ros_distro))

    def _pace(self, t_ns: int) -> None:
        now = time.perf_counter()
        if self._wall0 is None:
            self._wall0 = now - t_ns * 1e-9 / self.spec.real_time_factor
        ahead_s = self._wall0 + t_ns * 1e-9 / self.spec.real_time_factor - now
        if ahead_s > 0:
            time.sleep(ahead_s)
        self._check_alive(t_ns)

    def _count_late(self, t_ns: int) -> None:
        self.late += 1
        self._late_in_row += 1
        if self._late_in_row >= self.spec.max_late_in_row:
            waiting = ""
            if self.ledger is not None:
                missing = self.ledger.missing(Phase.SENSORS) + self.ledger.missing(Phase.CLOCK)
                waiting = f" (waiting for {', '.join(missing)})" if missing else ""
            raise RunError(f"external controller of {self.name}: no answer within "
                           f"{self.spec.tick_timeout_s:g} s for {self._late_in_row} ticks in a "
                           f"row (t={t_ns * 1e-9:.3f} s, {self.late} late in all){waiting}; "
                           f"{self._output()}")

    def _check_alive(self, t_ns: int) -> None:
        code = self.child.exited() if self.child is not None else None
        if code is not None:
            raise RunError(f"external controller of {self.name}: the program exited with code "
                           f"{code} at t={t_ns * 1e-9:.3f} s; {self._output()}")

    def _output(self) -> str:
        if self.child is None:
            return "no program was started by kartci"
        return f"last output: {self.child.tail()}"

    def _missing(self) -> list[str]:
        """What the stack has not declared yet: its /clock subscription, its command
        publishers (token fields 5 and 9-11: kind, mangled topic, type name, type hash)."""
        have = {(p[5], *p[9:12]) for p in (k.split("/") for k in list(self._tokens))
                if len(p) == 13}
        want = [("MS", "/clock", CLOCK)] + [("MP", t, ty) for t, ty in self.commands.items()]
        return [f"{'subscription to' if kind == 'MS' else 'publisher of'} {topic} ({typename})"
                for kind, topic, typename in want
                if (kind, ros2.mangle(topic), ros2.dds_type_name(typename),
                    ros2.type_hash(typename, self.spec.ros_distro)) not in have
                ] + unpublished(self._stack_endpoints(), self._published(), self._optional())

    def _published(self) -> set[str]:
        """The topics kartci publishes to the stack."""
        return {"/clock", *(self._full(t) for t in self.inputs)}

    def _optional(self) -> set[str]:
        """Topics the scenario says not to wait for (waits_for count 0): a subscription to one
        of them needs no publisher before t = 0."""
        return {self._full(w.topic) for w in self.spec.waits_for if w.count == 0}

    def _wait_ready(self) -> None:
        """The start barrier: the stack has declared its /clock subscription and command
        publishers, a publisher of everything it subscribes to (else a node is not up yet),
        and its graph has not changed for graph_settle_s; then what every tick waits for is
        planned, the stack's own topics are watched, and QoS checked."""
        deadline = time.perf_counter() + self.spec.startup_timeout_s
        declared = False
        while (missing := self._missing()) or (
                time.perf_counter() - self._tokens_changed < self.spec.graph_settle_s):
            if not missing and not declared:  # kartci's publishers inside the settling time
                self._declare()
                declared = True
            self._check_alive(0)
            if time.perf_counter() > deadline:
                raise RunError(f"external controller of {self.name}: within "
                               f"{self.spec.startup_timeout_s:g} s the stack declared no "
                               f"{', no '.join(missing)} on {self.endpoint}; "
                               f"{self._output()}")
            time.sleep(0.01)
        while not self.clock.matched():
            time.sleep(0.001)
        self._plan(self._stack_endpoints())
        assert self.ledger is not None
        for topic in self.ledger.expect:
            if topic not in self.commands:
                self.node.observe(topic, self._observer(topic))
        self._ready = True

    def _observer(self, topic: str) -> Callable[[int], None]:
        def seen(thread: int) -> None:
            self._routers.add(thread)
            self.inbox.push(topic, None)
        return seen

    def _hand_off(self) -> None:
        """Before /clock: the stack's messages kartci saw for this tick are on their way to
        the nodes they are for (Zenoh: the thread that routed each has finished its pass;
        beyond that, and where that cannot be told, `fence_s` of wall clock)."""
        threads, self._routers = self._routers, set()
        if not routed(threads, 1.0) or self.spec.fence_s:
            time.sleep(self.spec.fence_s)

    def _plan(self, stack: list[Endpoint]) -> None:
        """The ledger of what each tick waits for, from the stack's graph and waits_for; a
        QoS pair of the stack that can never match is an error naming both sides."""
        if problems := mismatches(stack):
            raise RunError(f"external controller of {self.name}: {'; '.join(problems)}")
        sensors = {self._full(t) for t in self.inputs}
        declared = {self._full(w.topic): Expect(w.count, w.every, w.after)
                    for w in self.spec.waits_for}
        wanted, may_answer_data = plan(stack, sensors, self.commands, declared)
        self.ledger = Ledger(wanted, may_answer_data, self.commands)

    def _outbox(self, got: dict[str, Any]) -> Outbox:
        out: Outbox = []
        for topic in sorted(got):
            m = got[topic]
            target = self.applied_on[self.commands[topic]]
            out.append((target, m))
            if target == "joy" and self.joystick is not None:
                out.append(self.joystick(m, self.frame))
        return out

    def _write_arrivals(self) -> None:
        """The arrival order of each tick's stack messages, beside the log (what `kartci run
        --conditioning K` compares between repeats that differ)."""
        if self.run_dir is not None and self._arrivals:
            write_text_atomic(self.run_dir / f"{self.name}.{ARRIVALS}",
                              "\n".join(self._arrivals) + "\n")
            self._arrivals = []

    def close(self) -> None:
        """Stop the stack's program and close the Zenoh session (idempotent)."""
        self._write_arrivals()
        if self.child is not None:
            self.child.stop(self.spec.stop_timeout_s)
        if not self.node.session.is_closed():
            self.node.close()
