"""One run's Zenoh session as a ROS 2 node: publishers and subscriptions with rmw_zenoh's keys,
attachments and liveliness tokens.

Isolation: the session is a peer that listens on a free loopback port of its own, with multicast
scouting off and no router, so nothing but the run's own stack (told the port) can reach it;
`-j N` runs are separate networks. Gossip is on (single hop, as in rmw_zenoh's default session
config): the session tells each process of the stack where the others listen, so a stack of
several processes all connected to kartci connect to each other too (peers route nothing for
others; without gossip they never meet). Joining more is explicit: endpoints to connect to (a
team's router), router mode, and rmw_zenoh's $ZENOH_CONFIG_OVERRIDE, all held to this host
unless the scenario allows remote endpoints.
"""

from __future__ import annotations

import ipaddress
import json
import os
import socket
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import zenoh

from kartci.bridge import ros2
from kartci.bridge.lockstep import Qos
from kartci.errors import RunError, SpecError

LOOPBACK = "127.0.0.1"
CONNECT_TIMEOUT_MS = 5000  # ms, to reach the endpoints to connect to (else an error)
OVERRIDE_ENV = "ZENOH_CONFIG_OVERRIDE"  # rmw_zenoh's: key=value;... of Zenoh config


def free_port() -> int:
    """A TCP port on the loopback that nothing listens on right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind((LOOPBACK, 0))
        return int(s.getsockname()[1])


def parse_override(text: str) -> list[tuple[str, str]]:
    """`ZENOH_CONFIG_OVERRIDE` as rmw_zenoh reads it: `key=value` items separated by `;`, each key
    a slash path of Zenoh's configuration, each value JSON5
    (`mode="router";listen/endpoints=["tcp/127.0.0.1:7447"]`)."""
    pairs = []
    for item in filter(None, (part.strip() for part in text.split(";"))):
        key, sep, value = item.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise SpecError(f"{OVERRIDE_ENV}: {item!r} is not key=value")
        pairs.append((key.strip(), value.strip()))
    return pairs


def is_loopback(endpoint: str) -> bool:
    """Whether a Zenoh endpoint (`tcp/127.0.0.1:7447`, `udp/[::1]:7447#...`) is on this host."""
    address = endpoint.partition("/")[2].split("#", 1)[0].split("?", 1)[0]
    host = address.rpartition(":")[0].strip("[]")
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def _endpoints(conf: zenoh.Config, key: str) -> list[str]:
    """The endpoints of `listen` or `connect`: a list, or one list per mode."""
    value = json.loads(conf.get_json(f"{key}/endpoints")) or []
    lists = value.values() if isinstance(value, dict) else [value]
    return [str(e) for endpoints in lists for e in endpoints or []]


def beyond_host(conf: zenoh.Config) -> list[str]:
    """What in a configuration reaches past this host: non-loopback endpoints, multicast."""
    out = [e for key in ("listen", "connect") for e in _endpoints(conf, key)
           if not is_loopback(e)]
    if json.loads(conf.get_json("scouting/multicast/enabled")) is not False:
        out.append("multicast scouting")
    return out


def session_config(listen: list[str], connect: list[str], router: bool,
                   override: str = "") -> zenoh.Config:
    """A peer (or a router) on the given endpoints: no multicast, no timestamps; gossip on so
    the processes connected to it learn each other's endpoints; a router to `connect` to must
    be there (no silent start alone). `override` (ZENOH_CONFIG_OVERRIDE) is applied last."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"router"' if router else '"peer"')
    conf.insert_json5("listen/endpoints", json.dumps(listen))
    conf.insert_json5("connect/endpoints", json.dumps(connect))
    if connect:
        conf.insert_json5("connect/exit_on_failure", '{router: true, peer: true, client: true}')
        conf.insert_json5("connect/timeout_ms", json.dumps(
            dict.fromkeys(("router", "peer", "client"), CONNECT_TIMEOUT_MS)))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "true")
    conf.insert_json5("scouting/gossip/multihop", "false")
    for key, value in parse_override(override):
        try:
            conf.insert_json5(key, value)
        except zenoh.ZError as err:
            raise SpecError(f"{OVERRIDE_ENV}: cannot set {key} to {value} ({err})") from err
    return conf


def open_listening(port: int | None = None, *, connect: tuple[str, ...] = (),
                   router: bool = False, allow_remote: bool = False,
                   attempts: int = 5) -> tuple[zenoh.Session, str]:
    """A session listening on `tcp/127.0.0.1:<port>` (default a free port), and that endpoint
    (a free port taken between the probe and the bind is retried). It connects to `connect`
    and takes $ZENOH_CONFIG_OVERRIDE; anything reaching past this host is refused unless
    `allow_remote`."""
    last: Exception | None = None
    override = os.environ.get(OVERRIDE_ENV, "")
    for _ in range(attempts if port is None else 1):
        endpoint = f"tcp/{LOOPBACK}:{port or free_port()}"
        conf = session_config([endpoint], list(connect), router, override)
        if not allow_remote and (remote := beyond_host(conf)):
            raise SpecError(f"bridge: {', '.join(remote)} reaches beyond this host; set "
                            "allow_remote: true in the external controller to allow it")
        try:
            return zenoh.open(conf), endpoint
        except zenoh.ZError as err:  # the port was taken meanwhile, or no router to join
            last = err
            if connect:
                break
    raise RunError(f"bridge: cannot listen on tcp/{LOOPBACK}:{port or '<free port>'}"
                   f"{' and connect to ' + ', '.join(connect) if connect else ''} ({last})")


class Publisher:
    """A ROS 2 publisher: CDR payloads with rmw_zenoh's attachment, and its `MP` token."""

    def __init__(self, node: Node, topic: str, typename: str, entity_id: int,
                 qos: Qos) -> None:
        self.typename = typename
        self.key = ros2.topic_key(node.name.domain_id, topic, typename, node.name.distro)
        # express: sent at once rather than batched (a batch waits up to a millisecond); one
        # priority for all, so a tick's messages still arrive in the order they were put;
        # BLOCK, not zenoh's default DROP: under load a full queue dropped a /clock or a
        # sensor message, the tick then timed out and the run lost its determinism (rmw_zenoh
        # also blocks for reliable KEEP_ALL publishers)
        self._pub = node.session.declare_publisher(
            self.key, express=True, congestion_control=zenoh.CongestionControl.BLOCK,
            reliability=zenoh.Reliability.RELIABLE)
        token = ros2.entity_token(node.name, entity_id, ros2.EntityKind.PUBLISHER, topic,
                                  typename, ros2.qos_text(qos))
        self._gid = ros2.gid(token)
        self._seq = 0
        self._token = node.session.liveliness().declare_token(token)

    def matched(self) -> bool:
        """Whether a subscriber's declaration has reached this publisher (until then a put
        may go nowhere)."""
        status: Any = self._pub.matching_status  # a MatchingStatus; the stub says bool
        return bool(status.matching)

    def put(self, payload: bytes) -> None:
        """Publish one serialised message (sequence numbers from 1, wall-clock source stamp)."""
        self._seq += 1
        self._pub.put(payload, attachment=ros2.attachment(self._seq, time.time_ns(), self._gid))


class Node:
    """A ROS 2 node named `name` on its own Zenoh session (closed with `close()`), speaking
    `distro`'s key format."""

    def __init__(self, session: zenoh.Session, domain_id: int, name: str,
                 distro: ros2.Distro = ros2.DEFAULT_DISTRO) -> None:
        self.session = session
        self.name = ros2.NodeName(domain_id, str(session.zid()), 0, name, distro=distro)
        self._entities: list[Any] = [session.liveliness().declare_token(
            ros2.node_token(self.name))]
        self._next_id = 10  # rmw_zenoh numbers a node's entities after its own id

    def _entity_id(self) -> int:
        self._next_id += 1
        return self._next_id

    def publisher(self, topic: str, typename: str, qos: Qos | None = None) -> Publisher:
        """Declare a publisher (and its token, saying `qos`) on a fully qualified topic."""
        pub = Publisher(self, topic, typename, self._entity_id(), qos or Qos())
        self._entities.append(pub)
        return pub

    def subscription(self, topic: str, typename: str,
                     on_payload: Callable[[bytes], None]) -> None:
        """Declare a subscription (and its token); `on_payload` gets each CDR payload, on a
        Zenoh thread."""
        key = ros2.topic_key(self.name.domain_id, topic, typename, self.name.distro)
        def take(sample: zenoh.Sample) -> None:
            on_payload(sample.payload.to_bytes())

        # indirect=False: called on the network thread, so samples keep their order
        sub = self.session.declare_subscriber(key, zenoh.handlers.Callback(take, indirect=False))
        token = self.session.liveliness().declare_token(ros2.entity_token(
            self.name, self._entity_id(), ros2.EntityKind.SUBSCRIPTION, topic, typename))
        self._entities += [sub, token]

    def observe(self, topic: str, on_sample: Callable[[int], None]) -> None:
        """Call `on_sample(thread)` for every message on `topic`, whatever its type, on the
        network thread that routes it (`thread`: its native id, see `routed`). No token: the
        stack's graph does not show it (a node that counts its subscribers sees none more)."""
        key = f"{self.name.domain_id}/{ros2.fully_qualified(topic)[1:]}/*/*"
        def seen(_: zenoh.Sample) -> None:
            on_sample(threading.get_native_id())

        self._entities.append(self.session.declare_subscriber(
            key, zenoh.handlers.Callback(seen, indirect=False)))

    def watch_tokens(self, on_token: Callable[[str], None]) -> None:
        """Call `on_token(key)` for every liveliness token of the domain, present or new."""
        sub = self.session.liveliness().declare_subscriber(
            f"{ros2.LIVELINESS_PREFIX}/{self.name.domain_id}/**",
            lambda sample: on_token(str(sample.key_expr))
            if sample.kind == zenoh.SampleKind.PUT else None, history=True)
        self._entities.append(sub)

    def close(self) -> None:
        """Close the session (its tokens vanish with it)."""
        self.session.close()  # type: ignore[no-untyped-call]


def routed(threads: set[int], timeout_s: float) -> bool:
    """Whether each of this process's network `threads` has finished what it was doing when
    it delivered a message here: Zenoh routes a message from one node to the others and to
    this session's subscribers in one pass on one thread, in an order of its own, so a message
    seen here may not yet be on its way to the node it is for. A thread that is no longer
    running (Linux: not `R` in /proc/self/task/<id>/stat) has finished that pass. False when
    `timeout_s` passed first, or where /proc cannot tell."""
    deadline = time.perf_counter() + timeout_s
    for tid in threads:
        while True:
            try:
                stat = Path(f"/proc/self/task/{tid}/stat").read_text()
            except OSError:
                if not Path("/proc/self/task").is_dir():
                    return False  # no /proc: cannot tell
                break  # the thread is gone: it has finished
            if stat.rsplit(")", 1)[1].split()[0] != "R":
                break
            if time.perf_counter() > deadline:
                return False
            time.sleep(0)  # let it run
    return True


class Inbox:
    """Messages from Zenoh threads, waited for by the simulation thread."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._items: list[tuple[str, bytes | None]] = []

    def push(self, topic: str, payload: bytes | None) -> None:
        """Add one payload, or None for a message only counted (called on a Zenoh thread)."""
        with self._cond:
            self._items.append((topic, payload))
            self._cond.notify_all()

    def take(self) -> list[tuple[str, bytes | None]]:
        """Everything received so far, oldest first."""
        with self._cond:
            out, self._items = self._items, []
        return out

    def wait(self, timeout_s: float) -> bool:
        """Wait until something is there (True) or the time is up (False)."""
        with self._cond:
            return self._cond.wait_for(lambda: bool(self._items), timeout=max(timeout_s, 0.0))
