"""`controller: {type: external}`: the robot's sensors and `/clock` go out over Zenoh, the stack's
commands come back and are published into the loop like an in-process agent's outbox (so they
are recorded and applied as usual).

Lockstep (the default): at every control tick the bridge publishes the tick's sensor messages,
then `/clock` at the tick's sim time, and waits until every command topic has answered that tick
(a stamped command must carry the tick's stamp; earlier ones are stale and dropped). A tick whose
answer misses `tick_timeout_s` of wall clock is a `late_commands` event (the last command holds);
`max_late_in_row` of them in a row, the stack's exit, or its absence at startup end the run as an
error naming the program's last output.
"""

from __future__ import annotations

import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from kartci import project
from kartci.bridge import ros2
from kartci.bridge.attach import announce, for_zenoh
from kartci.bridge.child import Child
from kartci.bridge.link import Inbox, Node, Publisher, open_listening
from kartci.bridge.params import COMMAND_TYPES, ExternalController, Mode
from kartci.core import ROBOTS, AgentContext, JoyCommand, Outbox, RobotParams
from kartci.errors import RunError, SpecError
from kartci.logs.types import base_link, msg, stamp_ns

CLOCK = "rosgraph_msgs/msg/Clock"
LATE_TOPIC = "bridge/late_commands"  # std_msgs/UInt32: the count so far, at each late tick


def child_env(endpoint: str, domain_id: int, namespace: str) -> dict[str, str]:
    """What the stack is told: the endpoint to connect to (kartci's variable, and Zenoh's
    override for rmw_zenoh nodes, which also need no router check), the domain, the namespace."""
    override = (f'mode="peer";connect/endpoints=["{endpoint}"];'
                'listen/endpoints=["tcp/127.0.0.1:0"];scouting/multicast/enabled=false')
    return {"KARTCI_ZENOH_ENDPOINT": endpoint, "ZENOH_CONFIG_OVERRIDE": override,
            "ZENOH_ROUTER_CHECK_ATTEMPTS": "-1", "ROS_DOMAIN_ID": str(domain_id),
            "KARTCI_NAMESPACE": namespace}


def substitute(text: str, values: dict[str, str]) -> str:
    """`{name}` placeholders replaced; any other brace (JSON in an argument) left alone."""
    for key, value in values.items():
        text = text.replace(f"{{{key}}}", value)
    return text


def joystick(agent: str, model: RobotParams, mapping: str) -> JoyCommand:
    """What the robot's kind makes of the stack's Joy messages through `mapping`."""
    make = ROBOTS.get(model.kind).joystick
    if make is None:
        raise SpecError(f"agent {agent}: a {model.kind} robot reads no joystick; command it "
                        "with another of the external controller's command types")
    return make(model, mapping)


class ExternalAgent:
    """The bridge for one agent: a Zenoh node, the stack's process, the lockstep."""

    inputs: tuple[str, ...]
    _pending: list[tuple[str, Any]]
    _wall0: float | None
    _latest: dict[str, Any]
    child: Child | None

    def __init__(self, spec: ExternalController, ctx: AgentContext) -> None:
        self._lockstep_state(spec, ctx)
        self._pubs: dict[tuple[str, str], Publisher] = {}
        self._tokens: set[str] = set()
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
            self.node.watch_tokens(self._tokens.add)
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
        self.joystick = joystick(ctx.name, ctx.model, spec.mapping) if any(
            c.type == "sensor_msgs/msg/Joy" for c in spec.commands) else None
        self.commands = {self._full(c.topic): c.type for c in spec.commands}
        self.late = self._late_in_row = 0
        self._pending = []
        self._ready = False
        self._wall0 = None
        self._latest = {}
        self.child = None
        self.inbox = Inbox()

    def _pusher(self, topic: str) -> Callable[[bytes], None]:
        def push(payload: bytes) -> None:
            self.inbox.push(topic, payload)
        return push

    def _full(self, topic: str) -> str:
        return topic if topic.startswith("/") else f"/{self.name}/{topic}"

    def _start(self, run_dir: Path | None) -> Child:
        root = project.current().root
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
        """Publish the tick's sensors and /clock; in lockstep wait for the stack's answer."""
        if not self._ready:
            self._wait_ready()
        if self.spec.mode is Mode.PACED:
            self._pace(t_ns)
        else:
            self.inbox.take()  # answers to earlier ticks that came after their deadline
        self._publish(t_ns)
        if self.spec.mode is Mode.PACED:
            self._receive(self.inbox.take(), None)
            return self._outbox(self._latest)
        got = self._await(t_ns)
        if got is None:
            return [(LATE_TOPIC, msg("std_msgs/msg/UInt32", data=self.late))]
        return self._outbox(got)

    def _declare(self) -> None:
        """A publisher for each new (topic, type) of the pending messages; before its first
        put, it waits until the stack's subscription (if its tokens show one) has matched."""
        new = []
        for topic, m in self._pending:
            typename = type(m).__msgtype__
            if (topic, typename) not in self._pubs:
                self._pubs[(topic, typename)] = pub = self.node.publisher(topic, typename)
                new.append((topic, typename, pub))
        if not new:
            return
        subscribed = self._stack_subscriptions()
        deadline = time.perf_counter() + self.spec.startup_timeout_s
        for topic, typename, pub in new:
            while (topic, typename) in subscribed and not pub.matched():
                if time.perf_counter() > deadline:
                    raise RunError(f"external controller of {self.name}: the stack's "
                                   f"subscription to {topic} never matched; {self._output()}")
                time.sleep(0.001)

    def _stack_subscriptions(self) -> set[tuple[str, str]]:
        """(topic, type) of every subscription the stack's liveliness tokens announce."""
        have = {(p[5], *p[9:12]) for p in (k.split("/") for k in list(self._tokens))
                if len(p) == 13}
        return {(topic, typename) for topic, typename in
                {(t, type(m).__msgtype__) for t, m in self._pending} | set(self._pubs)
                if ("MS", ros2.mangle(topic), ros2.dds_type_name(typename),
                    ros2.type_hash(typename, self.spec.ros_distro)) in have}

    def _publish(self, t_ns: int) -> None:
        self._declare()
        distro = self.spec.ros_distro
        for topic, m in self._pending:
            self._pubs[(topic, type(m).__msgtype__)].put(ros2.serialize(m, distro))
        self._pending.clear()
        sec, nanosec = divmod(t_ns, 1_000_000_000)
        self.clock.put(ros2.serialize(msg(CLOCK, clock=msg(
            "builtin_interfaces/msg/Time", sec=sec, nanosec=nanosec)), distro))

    def _pace(self, t_ns: int) -> None:
        now = time.perf_counter()
        if self._wall0 is None:
            self._wall0 = now - t_ns * 1e-9 / self.spec.real_time_factor
        ahead_s = self._wall0 + t_ns * 1e-9 / self.spec.real_time_factor - now
        if ahead_s > 0:
            time.sleep(ahead_s)
        self._check_alive(t_ns)

    def _receive(self, items: list[tuple[str, bytes]], t_ns: int | None) -> dict[str, Any]:
        """Decode answers; in lockstep (`t_ns` given) keep only those for this tick."""
        got: dict[str, Any] = {}
        for topic, payload in items:
            typename = self.commands[topic]
            try:
                m = ros2.deserialize(payload, typename, self.spec.ros_distro)
            except Exception as err:  # a malformed payload is the stack's error, named
                raise RunError(f"external controller of {self.name}: a {typename} on {topic} "
                               f"does not decode ({type(err).__name__}: {err})") from err
            if t_ns is not None and hasattr(m, "header") and stamp_ns(m.header) != t_ns:
                continue  # stale: an earlier tick's answer
            got[topic] = m
        self._latest.update(got)
        return got

    def _await(self, t_ns: int) -> dict[str, Any] | None:
        """Every command topic's answer to tick `t_ns`, or None when the deadline passed."""
        deadline = time.perf_counter() + self.spec.tick_timeout_s
        got: dict[str, Any] = {}
        while len(got) < len(self.commands):
            left = deadline - time.perf_counter()
            if left <= 0:
                self._count_late(t_ns)
                return None
            if self.inbox.wait(min(left, 0.05)):
                got.update(self._receive(self.inbox.take(), t_ns))
            else:
                self._check_alive(t_ns)
        self._late_in_row = 0
        return got

    def _count_late(self, t_ns: int) -> None:
        self.late += 1
        self._late_in_row += 1
        if self._late_in_row >= self.spec.max_late_in_row:
            raise RunError(f"external controller of {self.name}: no command within "
                           f"{self.spec.tick_timeout_s:g} s for {self._late_in_row} ticks in a "
                           f"row (t={t_ns * 1e-9:.3f} s, {self.late} late in all); "
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
                    ros2.type_hash(typename, self.spec.ros_distro)) not in have]

    def _wait_ready(self) -> None:
        deadline = time.perf_counter() + self.spec.startup_timeout_s
        while self._missing():
            self._check_alive(0)
            if time.perf_counter() > deadline:
                raise RunError(f"external controller of {self.name}: within "
                               f"{self.spec.startup_timeout_s:g} s the stack declared no "
                               f"{', no '.join(self._missing())} on {self.endpoint}; "
                               f"{self._output()}")
            time.sleep(0.01)
        while not self.clock.matched():
            time.sleep(0.001)
        self._ready = True

    def _outbox(self, got: dict[str, Any]) -> Outbox:
        out: Outbox = []
        for topic in sorted(got):
            m = got[topic]
            target = COMMAND_TYPES[self.commands[topic]]
            out.append((target, m))
            if target == "joy" and self.joystick is not None:
                out.append(self.joystick(m, self.frame))
        return out

    def close(self) -> None:
        """Stop the stack's program and close the Zenoh session (idempotent)."""
        if self.child is not None:
            self.child.stop(self.spec.stop_timeout_s)
        if not self.node.session.is_closed():
            self.node.close()
