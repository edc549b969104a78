"""The DDS side of the bridge: a program run under a ROS 2 Python (never kartci's), started by
kartci with one end of a socket pair. It is a ROS 2 node (rclpy on Fast DDS) that publishes what
kartci sends (sensor messages, then `/clock`) and sends back every command the stack publishes.

It relays CDR bytes without decoding them: kartci serialises and deserialises, rclpy publishes
raw (`Publisher.publish(bytes)`) and subscribes raw (`raw=True`), so a message here is the same
bytes as on the Zenoh bridge. It checks each type's RIHS01 hash against the installed definition
(`share/<pkg>/msg/<T>.json`) first, so a definition that differs (Humble's Range) is an error,
not a payload 4 bytes short.

The frames (both ways) are `<II` (header length, body length), a JSON header, a binary body. This
module imports only the standard library at the top: kartci imports it for the framing; rclpy
is imported in `main()` only, under the ROS 2 Python.

    python relay.py --socket PATH      (kartci's Unix socket; kartci runs it)
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import os
import select
import socket
import struct
import sys
import threading
import time
from pathlib import Path
from typing import Any

_FRAME = struct.Struct("<II")
MATCH_TIMEOUT_S = 10.0  # s, for a new publisher to match the stack's subscriptions to its topic
MISSING_PERIOD_S = 0.05  # s, between checks of the stack's graph while waiting for it


def send(sock: socket.socket, lock: threading.Lock, head: dict[str, Any],
         body: bytes = b"") -> None:
    """One frame; `lock` keeps frames of several threads whole."""
    data = json.dumps(head).encode()
    with lock:
        sock.sendall(_FRAME.pack(len(data), len(body)) + data + body)


def _exactly(sock: socket.socket, n: int) -> bytes | None:
    chunks, left = [], n
    while left:
        chunk = sock.recv(min(left, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def receive(sock: socket.socket) -> tuple[dict[str, Any], bytes] | None:
    """The next frame (header, body), or None when the other side has closed."""
    sizes = _exactly(sock, _FRAME.size)
    if sizes is None:
        return None
    n_head, n_body = _FRAME.unpack(sizes)
    head, body = _exactly(sock, n_head), _exactly(sock, n_body) if n_body else b""
    if head is None or body is None:
        return None
    out: dict[str, Any] = json.loads(head)
    return out, body


def description(typename: str) -> Path:
    """The installed type description `share/<pkg>/msg/<T>.json`: in $AMENT_PREFIX_PATH (a
    sourced ROS 2 installation) or this Python's prefix (the ros-rclpy wheels' layout)."""
    package, kind, name = typename.split("/")
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in [*prefixes, sys.prefix]:
        path = Path(prefix) / "share" / package / kind / f"{name}.json"
        if path.exists():
            return path
    where = ", ".join([*prefixes, sys.prefix])
    if any((Path(p) / "share" / package / kind / f"{name}.msg").exists()
           for p in [*prefixes, sys.prefix]):  # installed, without REP 2011's files: Humble
        raise RuntimeError(f"this ROS 2 has no type descriptions ({typename}: "
                           f"share/{package}/{kind}/{name}.msg but no {name}.json under "
                           f"{where}); the DDS relay needs them and runtime type hashes "
                           "(REP 2011: ROS 2 Iron and later), so a Humble stack cannot use "
                           "middleware dds: run it over middleware zenoh (ros_distro: humble)")
    raise RuntimeError(f"{typename}: no share/{package}/{kind}/{name}.json under {where} "
                       f"(is {package} installed?)")


INFRASTRUCTURE = ("/rosout", "/parameter_events")  # topics of every node, never awaited
# what rclpy's graph says of an endpoint whose node it has not learnt yet (a participant's node
# list comes on its own topic, after the endpoints): not a graph to plan from, nor to name
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"


def _qos(info: Any) -> tuple[int, int, int]:
    """(reliability, durability, depth) of an endpoint's QoS, as rmw's enum numbers."""
    q = info.qos_profile
    return int(q.reliability), int(q.durability), int(q.depth)


def _text(info: Any) -> str:
    """An endpoint's reliability and durability, as a person reads them."""
    rel, dur, _ = _qos(info)
    return (f"{ {1: 'reliable', 2: 'best-effort'}.get(rel, 'reliable')}, "
            f"{ {1: 'transient-local', 2: 'volatile'}.get(dur, 'volatile')}")


class Relay:
    """One rclpy node: publishers for what kartci sends, raw subscriptions for the commands and
    for the stack's own topics (counted: the lockstep waits for them), QoS as the stack asks."""

    def __init__(self, sock: socket.socket, start: dict[str, Any]) -> None:
        import rclpy  # the ROS 2 Python only (this module is also imported by kartci)

        self.sock, self.lock = sock, threading.Lock()
        for _, typename, hash_ in start["commands"]:  # a differing definition fails at once,
            self.cls(str(typename), str(hash_))  # before rclpy starts (nothing to shut down)
        rclpy.init(args=[])
        self.node = rclpy.create_node(start["node"])
        self.me = (self.node.get_name(), self.node.get_namespace())
        self.pubs: dict[tuple[str, str], Any] = {}
        self.commands = [(str(t), str(ty), str(h)) for t, ty, h in start["commands"]]
        self.watch = [str(t) for t in start.get("observe", [])]
        self.optional = [str(t) for t in start.get("optional", [])]
        self.settle_s = float(start.get("settle_s", 0.3))
        for topic, typename, hash_ in start["publishers"]:
            self.publisher(topic, typename, hash_, wait=False)
        self.subs: dict[str, Any] = {}  # commands, made once their publisher shows its QoS
        self.observers: dict[str, Any] = {}  # the stack's own topics, counted
        self.spinner = threading.Thread(target=rclpy.spin, args=(self.node,), daemon=True)
        self.spinner.start()

    def _sender(self, topic: str) -> Any:
        def forward(payload: bytes) -> None:
            with contextlib.suppress(OSError):  # kartci closed the socket: the relay ends
                send(self.sock, self.lock, {"op": "cmd", "topic": topic}, payload)
        return forward

    def _counter(self, topic: str) -> Any:
        def seen(_: bytes) -> None:
            with contextlib.suppress(OSError):
                send(self.sock, self.lock, {"op": "seen", "topic": topic})
        return seen

    def _request(self, infos: list[Any]) -> Any:
        """A subscription's QoS that matches every publisher in `infos`: reliable only if all
        offer it, volatile, deep enough never to drop a tick's messages."""
        from rclpy.qos import (  # the ROS 2 Python only
            DurabilityPolicy,
            QoSProfile,
            ReliabilityPolicy,
        )

        reliable = bool(infos) and all(
            i.qos_profile.reliability == ReliabilityPolicy.RELIABLE for i in infos)
        return QoSProfile(depth=100, durability=DurabilityPolicy.VOLATILE,
                          reliability=ReliabilityPolicy.RELIABLE if reliable
                          else ReliabilityPolicy.BEST_EFFORT)

    def _offer(self) -> Any:
        """A publisher's QoS that matches every subscription: reliable and transient-local
        (latched subscriptions: a track, /tf_static), keeping rmw's default 10. The same for
        every topic, so a publisher is made once, before the stack starts."""
        from rclpy.qos import (  # the ROS 2 Python only
            DurabilityPolicy,
            QoSProfile,
            ReliabilityPolicy,
        )

        return QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE,
                          durability=DurabilityPolicy.TRANSIENT_LOCAL)

    def _mine(self, info: Any) -> bool:
        return (info.node_name, info.node_namespace) == self.me

    def graph(self) -> list[list[Any]]:
        """Every publisher and subscription of the others: [node, kind, topic, type,
        reliability, durability, depth], sorted (a change means the graph moved)."""
        out = []
        for topic, _ in self.node.get_topic_names_and_types():
            for kind, infos in (("publisher", self.node.get_publishers_info_by_topic(topic)),
                                ("subscription",
                                 self.node.get_subscriptions_info_by_topic(topic))):
                for i in infos:
                    if not self._mine(i):
                        node = f"{i.node_namespace.rstrip('/')}/{i.node_name}"
                        out.append([node, kind, topic, i.topic_type, *_qos(i)])
        return sorted(out)

    def follow(self, graph: list[list[Any]]) -> None:
        """Subscribe to each command once its publisher shows, and to each of the stack's own
        topics (published and subscribed by the stack, or named by kartci) to count it."""
        commands = {t for t, _, _ in self.commands}
        for topic, typename, hash_ in self.commands:
            infos = self.node.get_publishers_info_by_topic(topic)
            if topic not in self.subs and any(i.topic_type == typename for i in infos):
                self.subs[topic] = self.node.create_subscription(
                    self.cls(typename, hash_), topic, self._sender(topic),
                    self._request(infos), raw=True)
        pubs = {(e[2], e[3]) for e in graph if e[1] == "publisher"}
        subs = {e[2] for e in graph if e[1] == "subscription"}
        for topic, typename in sorted(pubs):
            if topic in self.observers or topic in commands or topic in INFRASTRUCTURE or (
                    topic not in subs and topic not in self.watch):
                continue
            infos = self.node.get_publishers_info_by_topic(topic)
            self.observers[topic] = self.node.create_subscription(
                self.cls(typename, None), topic, self._counter(topic), self._request(infos),
                raw=True)

    def cls(self, typename: str, kartci_hash: str | None) -> Any:
        """The message class of `pkg/msg/T`, after its installed hash is found equal to
        kartci's (None: a type of the stack's own, only counted)."""
        package, kind, name = typename.split("/")
        if kartci_hash is None:
            try:
                return getattr(importlib.import_module(f"{package}.{kind}"), name)
            except (ImportError, AttributeError) as err:
                raise RuntimeError(f"the stack's topic type {typename} is not installed in "
                                   f"{sys.prefix}, so kartci cannot wait for it; set "
                                   "KARTCI_ROS2_PYTHON to the stack's own ROS 2 Python"
                                   ) from err
        path = description(typename)
        installed = json.loads(path.read_text())["type_hashes"][0]["hash_string"]
        if installed != kartci_hash:
            raise RuntimeError(f"{typename}: kartci's definition ({kartci_hash}) differs from "
                               f"the installed one ({installed}, {path})")
        return getattr(importlib.import_module(f"{package}.{kind}"), name)

    def publisher(self, topic: str, typename: str, hash_: str, wait: bool = True) -> Any:
        """The publisher of (topic, type), declared on first use; a new one waits until it has
        matched every subscription the graph shows on its topic (else its first messages could
        go nowhere)."""
        pub = self.pubs.get((topic, typename))
        if pub is None:
            pub = self.pubs[(topic, typename)] = self.node.create_publisher(
                self.cls(typename, hash_), topic, self._offer())
            deadline = time.monotonic() + MATCH_TIMEOUT_S
            while wait and pub.get_subscription_count() < self.node.count_subscribers(topic):
                if time.monotonic() > deadline:
                    raise RuntimeError(f"the stack's subscription to {topic} never matched")
                time.sleep(0.001)
        return pub

    def missing(self) -> list[str]:
        """What the stack has not declared yet: a /clock subscription, its command publishers
        (with kartci's type and hash), and their matches with this node."""
        out = []
        clock = self.pubs[("/clock", "rosgraph_msgs/msg/Clock")]
        if clock.get_subscription_count() < 1:
            out.append("subscription to /clock (rosgraph_msgs/msg/Clock)")
        # every subscription the graph shows on what kartci sends must be matched before the
        # first tick, or its first messages go nowhere (an odometry lost at start: the node
        # answered a tick later in one run of four, stalled_s 0.18 s instead of 0.02 s)
        for (topic, _), pub in self.pubs.items():
            if pub.get_subscription_count() < self.node.count_subscribers(topic):
                out.append(f"match of the stack's subscription to {topic}")
        for topic, typename, hash_ in self.commands:
            infos = self.node.get_publishers_info_by_topic(topic)
            kinds = {(i.topic_type, str(i.topic_type_hash)) for i in infos}
            sub = self.subs.get(topic)
            if (typename, hash_) not in kinds:
                seen = ", ".join(sorted(f"{t} {h}" for t, h in kinds))
                out.append(f"publisher of {topic} ({typename}"
                           + (f"; it has {seen}" if seen else "") + ")")
            elif sub is None or sub.get_publisher_count() < len(infos):
                offers = ", ".join(sorted({_text(i) for i in infos}))
                out.append(f"match of kartci's subscription to {topic} with the stack's "
                           f"publisher (it offers {offers})")
        # a subscription of the stack that nothing publishes: a node that is not up yet
        graph = self.graph()
        unnamed = sorted({e[2] for e in graph if UNKNOWN_NODE in e[0]})
        if unnamed:  # seen on CI: a QoS error named "_NODE_NAME_UNKNOWN_" for the relay
            out.append(f"the names of the nodes on {', '.join(unnamed)}")
        have = {e[2] for e in graph if e[1] == "publisher"} | {t for t, _ in self.pubs} | set(
            INFRASTRUCTURE) | set(self.optional)
        out += [f"publisher of {e[2]} (which {e[0]} subscribes to)" for e in graph
                if e[1] == "subscription" and e[2] not in have]
        for topic, sub in self.observers.items():
            stack = [i for i in self.node.get_publishers_info_by_topic(topic) if not self._mine(i)]
            if sub.get_publisher_count() < len(stack):
                out.append(f"match of kartci's watch on {topic} with the stack's publishers")
        return out

    def wait_ready(self) -> bool:
        """Tell kartci what is missing whenever that changes, then `ready` with the graph
        (True) once nothing is and the graph has not changed for settle_s; False when kartci
        has closed the socket meanwhile (it sends nothing before `ready`)."""
        last: list[str] | None = None
        graph: list[list[Any]] | None = None
        changed = time.monotonic()
        while True:
            now_graph = self.graph()
            if now_graph != graph:
                graph, changed = now_graph, time.monotonic()
                self.follow(graph)
            now = self.missing()
            if not now and time.monotonic() - changed >= self.settle_s:
                send(self.sock, self.lock, {"op": "ready", "graph": graph})
                return True
            if now != last:
                send(self.sock, self.lock, {"op": "missing", "what": now})
                last = now
            if select.select([self.sock], [], [], MISSING_PERIOD_S)[0]:
                return False  # readable before `ready`: only its end-of-file can be there

    def tick(self, head: dict[str, Any], body: bytes) -> None:
        """Publish a tick's messages in kartci's order (sensors, then /clock)."""
        at = 0
        for topic, typename, hash_, size in head["msgs"]:
            self.publisher(topic, typename, hash_).publish(body[at:at + size])
            at += size

    def close(self) -> None:
        """Destroy the node and shut rclpy down (Fast DDS removes its shared memory)."""
        import rclpy  # the ROS 2 Python only

        self.node.destroy_node()
        rclpy.try_shutdown()
        self.spinner.join(timeout=2.0)


def main() -> int:
    """Serve kartci until it closes the socket (a frame other than `tick` or `restart` also
    ends it)."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--socket", required=True, help="kartci's Unix socket to connect to")
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.connect(p.parse_args().socket)
    first = receive(sock)
    if first is None or first[0].get("op") != "start":
        return 2
    relay: Relay | None = None
    try:
        relay = Relay(sock, first[0])
        send(sock, relay.lock, {"op": "publishing"})  # kartci starts the stack now
        if not relay.wait_ready():
            return 0
        while (frame := receive(sock)) is not None:
            if frame[0]["op"] == "tick":
                relay.tick(*frame)
            elif frame[0]["op"] == "restart":  # kartci started the stack again
                relay.settle_s = float(frame[0]["settle_s"])
                if not relay.wait_ready():
                    return 0
            else:
                break
    except Exception as err:  # any failure goes to kartci as one line, then exit 1
        lock = relay.lock if relay is not None else threading.Lock()
        with contextlib.suppress(OSError):  # kartci is gone
            send(sock, lock, {"op": "error", "message": f"{type(err).__name__}: {err}"})
        print(f"relay: {type(err).__name__}: {err}", file=sys.stderr, flush=True)
        return 1
    finally:
        if relay is not None:
            relay.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
