"""Lockstep with a stack of several nodes: what kartci waits for before it moves sim time on.

A tick has two phases. kartci publishes the tick's sensor messages, then waits until every topic
the stack publishes *in response to data* has published for this tick (phase `sensors`); only
then does it publish `/clock`, and waits until every topic the stack publishes *in response to
time* and every command topic has published for this tick (phase `clock`). So a node that acts
on `/clock` (a timer under `use_sim_time`, or "answer at every clock") has the data of its tick
from the other nodes before its time moves, and the next tick's data is never published while
the stack is still busy with this one.

What to wait for is the stack's graph (its publishers and subscriptions, as rmw_zenoh's tokens
or DDS discovery show them): every topic a node of the stack publishes and another subscribes
to, once per tick, and every command topic. Whether a topic answers data or time is learnt at
tick 0 (a topic whose publisher reads no data at all is time's; one that has not published
`LEARN_QUIET_S` after the last message is time's too), unless the scenario states it with
`waits_for`, which also states counts other than one a tick (multi-rate nodes).

Messages are matched to ticks by count: the k-th message of a topic belongs to the tick in
which that topic was due for the k-th time. A late message therefore never answers a later
tick (late then stale is late twice), and a topic that publishes more than it was due in a
tick is an error naming it, not a silent shift.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from enum import Enum

ARRIVALS = "arrivals.log"  # <agent>.<this> in the run folder: each tick's stack messages in order
LEARN_QUIET_S = 0.5  # s of wall clock without a message that ends tick 0's learning wait
# topics every ROS 2 node has, which answer neither data nor time
INFRASTRUCTURE = ("/rosout", "/parameter_events")


class Phase(Enum):
    """What a topic of the stack answers within a tick."""

    SENSORS = "sensors"  # the tick's sensor messages: awaited before /clock is published
    CLOCK = "clock"  # the tick's /clock: awaited after it


class Reliability(Enum):
    """ROS 2 reliability as rmw reports it (the numbers of rmw's enum)."""

    SYSTEM_DEFAULT = 0
    RELIABLE = 1
    BEST_EFFORT = 2


class Durability(Enum):
    """ROS 2 durability as rmw reports it (the numbers of rmw's enum)."""

    SYSTEM_DEFAULT = 0
    TRANSIENT_LOCAL = 1
    VOLATILE = 2


class Kind(Enum):
    """An endpoint's side."""

    PUBLISHER = "publisher"
    SUBSCRIPTION = "subscription"


@dataclass(frozen=True)
class Qos:
    """The two QoS policies that decide whether a publisher and a subscription match."""

    reliability: Reliability = Reliability.RELIABLE
    durability: Durability = Durability.VOLATILE
    depth: int = 10  # messages kept (KEEP_LAST); 0 for KEEP_ALL

    def __str__(self) -> str:
        return (f"{self.reliability.name.lower().replace('_', '-')}, "
                f"{self.durability.name.lower().replace('_', '-')}")

    @property
    def reliable(self) -> bool:
        """Whether it is reliable (rmw's system default is reliable)."""
        return self.reliability is not Reliability.BEST_EFFORT

    @property
    def latched(self) -> bool:
        """Whether it is transient-local."""
        return self.durability is Durability.TRANSIENT_LOCAL


def offer_for(requests: Iterable[Qos]) -> Qos:
    """What kartci's publisher offers a topic: reliable and, where a subscription asks for it,
    transient-local, keeping as many messages as the deepest subscription (an offer at least
    every request matches every subscription)."""
    requests = list(requests)
    return Qos(Reliability.RELIABLE,
               Durability.TRANSIENT_LOCAL if any(q.latched for q in requests)
               else Durability.VOLATILE,
               max([q.depth for q in requests if q.depth > 0], default=10))


@dataclass(frozen=True)
class Endpoint:
    """A publisher or subscription of the stack, as the graph shows it."""

    node: str  # fully qualified node name (`/ns/name`)
    kind: Kind
    topic: str  # fully qualified
    typename: str  # pkg/msg/Type
    qos: Qos = field(default_factory=Qos)


def mismatches(endpoints: Iterable[Endpoint]) -> list[str]:
    """Publisher / subscription pairs of one topic and type that can never match (ROS 2: the
    offer must be at least the request), each naming both sides' QoS."""
    eps = list(endpoints)
    out = []
    for sub in (e for e in eps if e.kind is Kind.SUBSCRIPTION):
        for pub in (e for e in eps if e.kind is Kind.PUBLISHER and e.topic == sub.topic
                    and e.typename == sub.typename):
            why = []
            if sub.qos.reliable and not pub.qos.reliable:
                why.append("reliability")
            if sub.qos.latched and not pub.qos.latched:
                why.append("durability")
            if why:
                out.append(f"{sub.topic}: {pub.node}'s publisher offers {pub.qos}, "
                           f"{sub.node}'s subscription asks {sub.qos}; they never match "
                           f"({' and '.join(why)})")
    return out


def unpublished(endpoints: Iterable[Endpoint], published: Iterable[str],
                optional: Iterable[str]) -> list[str]:
    """What the stack subscribes to that nothing publishes yet (kartci's `published` topics,
    `/rosout`, `/parameter_events` and the `optional` ones aside): a node of the stack that
    is not up yet, so t = 0 waits for it."""
    eps = list(endpoints)
    have = {e.topic for e in eps if e.kind is Kind.PUBLISHER} | set(published) | set(
        INFRASTRUCTURE) | set(optional)
    return [f"publisher of {e.topic} (which {e.node} subscribes to)"
            for e in sorted(eps, key=lambda e: (e.topic, e.node))
            if e.kind is Kind.SUBSCRIPTION and e.topic not in have]


@dataclass(frozen=True)
class Expect:
    """One topic a tick waits for: `count` messages every `every` ticks, in `phase` (None:
    learnt at tick 0)."""

    count: int = 1
    every: int = 1
    phase: Phase | None = None

    def due(self, tick: int) -> int:
        """Messages due in tick `tick` (0-based)."""
        return self.count if tick % self.every == 0 else 0

    def due_before(self, tick: int) -> int:
        """Messages due in ticks 0 .. tick-1."""
        return self.count * ((tick + self.every - 1) // self.every)


def plan(endpoints: Iterable[Endpoint], sensors: Iterable[str], commands: Iterable[str],
         declared: Mapping[str, Expect]) -> tuple[dict[str, Expect], set[str]]:
    """What every tick waits for, and which of those topics may answer data.

    Awaited: every command topic and every topic the stack both publishes and subscribes to
    (`/rosout` and `/parameter_events` aside); `declared` (the scenario's `waits_for`) adds to
    and overrides that (count 0: never awaited). May answer data: a topic published by a node
    that subscribes to one of kartci's sensor topics or to another such topic."""
    eps = list(endpoints)
    pubs = {e.topic for e in eps if e.kind is Kind.PUBLISHER} - set(INFRASTRUCTURE)
    subs = {e.topic for e in eps if e.kind is Kind.SUBSCRIPTION}
    wanted = {t: Expect() for t in sorted((pubs & subs) | set(commands))}
    wanted.update(declared)
    wanted = {t: e for t, e in wanted.items() if e.count > 0}
    fed, reads = set(sensors), dict[str, set[str]]()
    for e in eps:
        reads.setdefault(e.node, set())
        if e.kind is Kind.SUBSCRIPTION:
            reads[e.node].add(e.topic)
    while True:
        more = {e.topic for e in eps if e.kind is Kind.PUBLISHER and reads[e.node] & fed} - fed
        if not more:
            break
        fed |= more
    return wanted, fed & set(wanted)


class Ledger:
    """Messages of the awaited topics counted into ticks; the tick-0 learning of phases."""

    def __init__(self, wanted: Mapping[str, Expect], may_answer_data: set[str],
                 commands: Iterable[str]) -> None:
        self.expect = dict(wanted)
        self.commands = set(commands)
        self.may_answer_data = set(may_answer_data)
        self.seen = dict.fromkeys(self.expect, 0)
        self.tick = 0

    def learning(self) -> bool:
        """Whether some topic's phase is still to be learnt (tick 0 only)."""
        return any(e.phase is None and t not in self.commands for t, e in self.expect.items())

    def count(self, topic: str) -> int:
        """Record one message of `topic`; its index among the topic's messages."""
        k = self.seen.get(topic, 0)
        self.seen[topic] = k + 1
        return k

    def belongs(self, topic: str, index: int) -> int:
        """-1: an earlier tick's (stale); 0: this tick's; 1: beyond what this tick is due."""
        e = self.expect.get(topic)
        if e is None:
            return 0
        start = e.due_before(self.tick)
        return -1 if index < start else 0 if index < start + e.due(self.tick) else 1

    def phase_of(self, topic: str) -> Phase:
        """The phase a topic is awaited in (commands: always after /clock; a topic still being
        learnt: sensors while it may answer data)."""
        e = self.expect[topic]
        if topic in self.commands:
            return Phase.CLOCK
        return e.phase or (Phase.SENSORS if topic in self.may_answer_data else Phase.CLOCK)

    def awaits(self, phase: Phase) -> bool:
        """Whether this tick waits for some topic in `phase`."""
        return any(self.phase_of(t) is phase and e.due(self.tick)
                   for t, e in self.expect.items())

    def missing(self, phase: Phase, learnt_only: bool = False) -> list[str]:
        """Topics of `phase` (learning: those that may be) not yet complete for this tick;
        with `learnt_only`, only those whose phase is known."""
        return [t for t, e in self.expect.items()
                if self.phase_of(t) is phase and self.seen[t] < e.due_before(self.tick + 1)
                and not (learnt_only and e.phase is None and t not in self.commands)]

    def learn(self, phase: Phase) -> None:
        """At tick 0, after `phase`'s wait: a topic complete by the end of the sensors phase
        answers data, one complete by the end of the clock phase answers time, one that never
        published is not a per-tick topic (not awaited)."""
        for t, e in list(self.expect.items()):
            if e.phase is not None:
                continue
            done = self.seen[t] >= e.due_before(1)
            if phase is Phase.SENSORS:
                if done and t not in self.commands:
                    self.expect[t] = Expect(e.count, e.every, Phase.SENSORS)
                else:
                    self.may_answer_data.discard(t)
            else:
                if done or t in self.commands:
                    self.expect[t] = Expect(e.count, e.every, Phase.CLOCK)
                else:
                    del self.expect[t]
                    del self.seen[t]

    def next_tick(self, stamped: Iterable[str] = ()) -> None:
        """The tick is over. `stamped` topics are matched by their stamps, not counts: a
        tick without their answer is forgiven in the count (its lateness is counted apart)."""
        self.tick += 1
        for t in stamped:
            if t in self.expect:
                self.seen[t] = self.expect[t].due_before(self.tick)

    def waits_for(self) -> list[dict[str, object]]:
        """The plan as the scenario's `waits_for` states it (what a team pastes to pin it)."""
        return [{"topic": t, "after": (e.phase or Phase.CLOCK).value, "count": e.count,
                 **({"every": e.every} if e.every != 1 else {})}
                for t, e in sorted(self.expect.items())]
