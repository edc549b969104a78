"""`kartci run --live`: a WebSocket client speaking Foxglove's protocol (subprotocol
foxglove.sdk.v1 in foxglove-sdk 0.30) connects to the running scenario on 127.0.0.1, sees its
channels advertised with their ros2msg schemas, subscribes, and receives the run's messages as it
runs, CDR that decodes to the same kind of messages the log holds; latched topics reach a client
that subscribed after they were published."""

from __future__ import annotations

import asyncio
import json
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from kartci.logs.types import typestore

websockets = pytest.importorskip("websockets", reason="websockets (dev extra) is the test client")
pytest.importorskip("foxglove", reason="foxglove-sdk (kartci[live]) serves --live")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


async def _connect(port: int, deadline: float) -> Any:
    """Connect, retrying while the server starts."""
    while True:
        try:
            return await websockets.connect(f"ws://127.0.0.1:{port}",
                                            subprotocols=["foxglove.sdk.v1"])
        except OSError:
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.05)


class Seen:
    """What the client saw: server info, channels by id, and (topic, log time, payload)."""

    def __init__(self) -> None:
        self.info: dict[str, Any] = {}
        self.channels: dict[int, dict[str, Any]] = {}
        self.subs: dict[int, int] = {}  # subscription id -> channel id
        self.messages: list[tuple[str, int, bytes]] = []

    def text(self, m: dict[str, Any]) -> list[dict[str, int]]:
        """A JSON message; the subscriptions to ask for (new channels)."""
        if m["op"] == "serverInfo":
            self.info = m
        if m["op"] != "advertise":
            return []
        new = [c for c in m["channels"] if c["id"] not in self.channels]
        out = []
        for c in new:
            self.channels[c["id"]] = c
            self.subs[len(self.subs) + 1] = c["id"]
            out.append({"id": len(self.subs), "channelId": c["id"]})
        return out

    def binary(self, raw: bytes) -> None:
        """Message data (opcode 1): subscription id, log time, payload."""
        if raw[0] == 1:
            sid, t_ns = struct.unpack_from("<IQ", raw, 1)
            self.messages.append((self.channels[self.subs[sid]]["topic"], t_ns, raw[13:]))


async def _client(port: int, deadline: float) -> Seen:
    """Subscribe to every channel as it is advertised, collect until the server goes away."""
    ws = await _connect(port, deadline)
    seen = Seen()
    try:
        async for raw in ws:
            if isinstance(raw, str):
                subs = seen.text(json.loads(raw))
                if subs:
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
            else:
                seen.binary(raw)
            if time.monotonic() > deadline:
                break
    except websockets.ConnectionClosed:
        pass
    return seen


@pytest.mark.long(reason="kartci runs end to end")
def test_live_run_serves_channels_and_messages(tmp_path: Path) -> None:
    port = _free_port()
    (tmp_path / "baselines").mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-m", "kartci.cli", "run", "line_straight", "--set", "duration_s=3",
         "--set", "criteria={}", "--set", "metrics.line_tracking.transient_s=1", "--live",
         "--live-port", str(port), "--out", tmp_path / "out",
         "--baselines", tmp_path / "baselines", "--no-strict"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        seen = asyncio.run(_client(port, time.monotonic() + 60))
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert f"live: ws://127.0.0.1:{port}" in err
    assert seen.info["name"] == "kartci"
    by_topic = {c["topic"]: c for c in seen.channels.values()}
    assert {"/lt0/odom", "/lt0/line_sensor", "/lt0/wheel_cmd", "/tf_static",
            "/lt0/robot_description", "/kartci/scenario"} <= set(by_topic)
    odom = by_topic["/lt0/odom"]
    assert (odom["encoding"], odom["schemaName"], odom["schemaEncoding"]) == (
        "cdr", "nav_msgs/msg/Odometry", "ros2msg")
    topics = [t for t, _, _ in seen.messages]
    assert "/tf_static" in topics and "/lt0/robot_description" in topics  # latched: resent
    store = typestore()
    odoms: list[tuple[int, Any]] = [(t, store.deserialize_cdr(data, "nav_msgs/msg/Odometry"))
             for topic, t, data in seen.messages if topic == "/lt0/odom"]
    assert len(odoms) > 20  # a run's worth, not one message
    times = [t for t, _ in odoms]
    assert times == sorted(times) and times[-1] == 3_000_000_000  # the run's last moment
    assert all(m.child_frame_id == "lt0/base_link" for _, m in odoms)
    assert (tmp_path / "out" / "line_straight" / "run.mcap").is_file()  # and it was logged


def test_live_needs_one_run_at_a_time(tmp_path: Path) -> None:
    res = subprocess.run([sys.executable, "-m", "kartci.cli", "run", "line_straight", "--live",
                          "-j", "2", "--out", tmp_path / "out"], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 2
    assert res.stderr.strip().splitlines()[-1].startswith("kartci: error: --live serves one run")
