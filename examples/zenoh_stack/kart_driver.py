"""A go-kart driver that is not kartci code: a separate program, as a team's ROS 2 stack would be.

It speaks rmw_zenoh's wire conventions with nothing but eclipse-zenoh and a CDR library
(rosbags' serialiser): it subscribes to `/<ns>/odom` (nav_msgs/Odometry), `/kartci/track`
(std_msgs/String, the track's CSV) and `/clock` (rosgraph_msgs/Clock), and at every clock tick
publishes one `/<ns>/ackermann_cmd` (ackermann_msgs/AckermannDriveStamped) stamped with that
tick's time: pure pursuit on the centreline, speed from the curvature ahead.

    python kart_driver.py --connect tcp/127.0.0.1:7447 [--namespace kart0] [--domain-id 0]

The endpoint defaults to $KARTCI_ZENOH_ENDPOINT (kartci sets it for the program it starts).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import queue
import signal
import struct
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import zenoh
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ACKERMANN = {
    "ackermann_msgs/msg/AckermannDrive": "float32 steering_angle\nfloat32 "
    "steering_angle_velocity\nfloat32 speed\nfloat32 acceleration\nfloat32 jerk\n",
    "ackermann_msgs/msg/AckermannDriveStamped": "std_msgs/Header header\n"
    "ackermann_msgs/AckermannDrive drive\n",
}
QOS = "::,10:,:,:,,"


def typestore() -> Any:
    """ROS 2 Humble's messages plus ackermann_msgs."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    types: dict[str, Any] = {}
    for name, text in ACKERMANN.items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


class Ros2Node:
    """Just enough of rmw_zenoh: keys, tokens, attachments (ros2/rmw_zenoh docs/design.md)."""

    def __init__(self, session: zenoh.Session, store: Any, domain_id: int, name: str) -> None:
        self.session, self.store, self.domain, self.name = session, store, domain_id, name
        self.zid = str(session.zid())
        self.keep: list[Any] = [session.liveliness().declare_token(
            f"@ros2_lv/{domain_id}/{self.zid}/0/0/NN/%/%/{name}")]
        self.next_id = 10

    def _names(self, typename: str) -> tuple[str, str]:
        pkg, kind, msg = typename.split("/")
        return f"{pkg}::{kind}::dds_::{msg}_", str(self.store.hash_rihs01(typename))

    def _token(self, kind: str, topic: str, typename: str) -> int:
        self.next_id += 1
        dds, h = self._names(typename)
        self.keep.append(self.session.liveliness().declare_token(
            f"@ros2_lv/{self.domain}/{self.zid}/0/{self.next_id}/{kind}/%/%/{self.name}/"
            f"{topic.replace('/', '%')}/{dds}/{h}/{QOS}"))
        return self.next_id

    def key(self, topic: str, typename: str) -> str:
        """`<domain>/<topic>/<dds type name>/<RIHS01 hash>`."""
        dds, h = self._names(typename)
        return f"{self.domain}/{topic.lstrip('/')}/{dds}/{h}"

    def subscribe(self, topic: str, typename: str, inbox: queue.Queue[Any]) -> None:
        """Decoded messages of `topic` into `inbox`, in arrival order, and an `MS` token."""
        # indirect=False: called on the network thread itself, so samples of different topics
        # stay in the order they were published (sensors first, then /clock)
        def take(sample: zenoh.Sample) -> None:
            inbox.put((topic, self.store.deserialize_cdr(sample.payload.to_bytes(), typename)))

        self.keep.append(self.session.declare_subscriber(
            self.key(topic, typename), zenoh.handlers.Callback(take, indirect=False)))
        self._token("MS", topic, typename)

    def raw_subscribe(self, topic: str, typename: str, take: Callable[[bytes], None]) -> None:
        """`take(payload)` for each CDR payload of `topic`, on the network thread; an `MS`
        token (declared after the subscriber, as rmw_zenoh does)."""
        def on_sample(sample: zenoh.Sample) -> None:
            take(sample.payload.to_bytes())

        self.keep.append(self.session.declare_subscriber(
            self.key(topic, typename), zenoh.handlers.Callback(on_sample, indirect=False)))
        self._token("MS", topic, typename)

    def raw_publisher(self, topic: str, typename: str) -> Callable[[bytes], None]:
        """A function that publishes a CDR payload with rmw_zenoh's attachment; an `MP` token."""
        # BLOCK: never drop a command under load (zenoh's default drops when a queue is full,
        # and kartci, in lockstep, would wait for the lost answer until its deadline)
        pub = self.session.declare_publisher(self.key(topic, typename), express=True,
                                             congestion_control=zenoh.CongestionControl.BLOCK)
        self.keep.append(pub)
        gid = hashlib.sha256(f"{self.zid}/{self._token('MP', topic, typename)}".encode()
                             ).digest()[:16]
        seq = [0]

        def put(payload: bytes) -> None:
            seq[0] += 1
            pub.put(payload, attachment=struct.pack("<qqB16s", seq[0], time.time_ns(), 16, gid))
        return put

    def publisher(self, topic: str, typename: str) -> Callable[[Any], None]:
        """A function that publishes a message (serialised here) on `topic`."""
        put = self.raw_publisher(topic, typename)
        return lambda message: put(bytes(self.store.serialize_cdr(message, typename)))


class PurePursuit:
    """Pure pursuit on the track's centreline; the speed follows the curvature ahead."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.xy: np.ndarray | None = None

    def set_track(self, csv_text: str) -> None:
        """The centreline from the track CSV (x_m, y_m, ...), resampled every 0.1 m."""
        rows = [line.split(",")[:2] for line in csv_text.splitlines()
                if line.strip() and not line.lstrip().startswith("#")]
        pts = np.array(rows, dtype=float)
        pts = np.vstack([pts, pts[:1]])
        seg = np.hypot(*np.diff(pts, axis=0).T)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        u = np.arange(0.0, s[-1], 0.1)
        self.xy = np.column_stack([np.interp(u, s, pts[:, 0]), np.interp(u, s, pts[:, 1])])
        n = len(self.xy)
        k = 10  # three-point curvature over +-1 m
        a, b, c = np.roll(self.xy, k, 0), self.xy, np.roll(self.xy, -k, 0)
        cross = ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                 - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
        la, lb, lc = (np.hypot(*(b - a).T), np.hypot(*(c - b).T), np.hypot(*(c - a).T))
        self.kappa = np.abs(2 * cross / np.maximum(la * lb * lc, 1e-9))
        self.n = n

    def command(self, x: float, y: float, yaw: float, v: float) -> tuple[float, float]:
        """(wheel angle rad, speed m/s)."""
        assert self.xy is not None
        a = self.args
        i = int(np.argmin(np.hypot(self.xy[:, 0] - x, self.xy[:, 1] - y)))
        gx, gy = self.xy[(i + round(a.lookahead_m / 0.1)) % self.n]
        alpha = math.atan2(gy - y, gx - x) - yaw
        delta = math.atan2(2 * a.wheelbase_m * math.sin(alpha), a.lookahead_m)
        ahead = self.kappa[(i + np.arange(round(max(8.0, 2 * v) / 0.1))) % self.n]
        kappa = max(float(ahead.max()), 1e-3)
        return delta, min(a.speed_mps, math.sqrt(a.max_lateral_accel_mps2 / kappa))


def parse() -> argparse.Namespace:
    """The command line."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--connect", default=os.environ.get("KARTCI_ZENOH_ENDPOINT"),
                   help="Zenoh endpoint of the simulator (default $KARTCI_ZENOH_ENDPOINT)")
    p.add_argument("--namespace", default=os.environ.get("KARTCI_NAMESPACE", "kart0"))
    p.add_argument("--domain-id", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    p.add_argument("--odom-topic", default="odom",
                   help="odometry topic, relative to the namespace (odom_relay behind a relay)")
    p.add_argument("--speed-mps", type=float, default=5.0)
    p.add_argument("--lookahead-m", type=float, default=3.5)
    p.add_argument("--wheelbase-m", type=float, default=1.27)
    p.add_argument("--max-lateral-accel-mps2", type=float, default=4.0)
    p.add_argument("--crash-at-s", type=float, default=None, help="(tests) exit 3 at this time")
    p.add_argument("--hang-at-s", type=float, default=None, help="(tests) stop answering")
    p.add_argument("--delay-s", type=float, default=0.0, help="(tests) answer this late")
    args = p.parse_args()
    if not args.connect:
        p.error("no endpoint: give --connect or set KARTCI_ZENOH_ENDPOINT")
    return args


def config(endpoint: str) -> zenoh.Config:
    """A peer that connects to the simulator only (loopback, no multicast, no gossip), then
    $ZENOH_CONFIG_OVERRIDE's `key=value;...` applied as rmw_zenoh applies it (kartci makes the
    programs it starts clients of its session this way)."""
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("listen/endpoints", json.dumps(["tcp/127.0.0.1:0"]))
    conf.insert_json5("scouting/multicast/enabled", "false")
    conf.insert_json5("scouting/gossip/enabled", "false")
    for item in filter(None, os.environ.get("ZENOH_CONFIG_OVERRIDE", "").split(";")):
        key, _, value = item.partition("=")
        conf.insert_json5(key.strip(), value.strip())
    if json.loads(conf.get_json("mode")) == "client":
        conf.insert_json5("listen/endpoints", "[]")
    return conf


def main() -> int:
    """Connect, declare, and answer every /clock tick until SIGTERM."""
    args = parse()
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    store = typestore()
    session = zenoh.open(config(args.connect))
    node = Ros2Node(session, store, args.domain_id, "pure_pursuit")
    inbox: queue.Queue[Any] = queue.Queue()
    ns = f"/{args.namespace}"
    node.subscribe(f"{ns}/{args.odom_topic}", "nav_msgs/msg/Odometry", inbox)
    node.subscribe("/kartci/track", "std_msgs/msg/String", inbox)
    publish = node.publisher(f"{ns}/ackermann_cmd", "ackermann_msgs/msg/AckermannDriveStamped")
    node.subscribe("/clock", "rosgraph_msgs/msg/Clock", inbox)  # last: kartci starts on it
    print(f"pure_pursuit: connected to {args.connect}, namespace {ns}", flush=True)
    driver, pose = PurePursuit(args), None
    header_t = store.types["std_msgs/msg/Header"]
    drive_t = store.types["ackermann_msgs/msg/AckermannDrive"]
    stamped_t = store.types["ackermann_msgs/msg/AckermannDriveStamped"]
    while True:
        topic, m = inbox.get()
        if topic == "/kartci/track":
            driver.set_track(m.data)
        elif topic == f"{ns}/{args.odom_topic}":
            p, q = m.pose.pose.position, m.pose.pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            pose = (p.x, p.y, yaw, m.twist.twist.linear.x)
        elif topic == "/clock":
            t_s = m.clock.sec + m.clock.nanosec * 1e-9
            if args.crash_at_s is not None and t_s >= args.crash_at_s:
                print(f"pure_pursuit: crashing on purpose at t={t_s:.2f} s", file=sys.stderr,
                      flush=True)
                return 3
            if args.hang_at_s is not None and t_s >= args.hang_at_s:
                print(f"pure_pursuit: hanging on purpose at t={t_s:.2f} s", file=sys.stderr,
                      flush=True)
                time.sleep(3600)
            if args.delay_s:
                time.sleep(args.delay_s)
            delta, speed = (0.0, 0.0) if pose is None or driver.xy is None else (
                driver.command(*pose))
            publish(stamped_t(
                header=header_t(stamp=m.clock, frame_id=f"{args.namespace}/base_link"),
                drive=drive_t(steering_angle=delta, steering_angle_velocity=0.0, speed=speed,
                              acceleration=0.0, jerk=0.0)))


if __name__ == "__main__":
    sys.exit(main())
