"""`kartci run --live`: a WebSocket client speaking Foxglove's protocol (foxglove.websocket.v1)
(foxglove-sdk 0.30 names it foxglove.sdk.v1) connects to the running scenario on 127.0.0.1, sees its channels advertised with their ros2msg
schemas, subscribes, and receives the run's messages as it runs, CDR that decodes to the same
kind of messages the log holds; a latched topic reaches a client that subscribed late."""

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


async def _client(port: int, deadline: float) -> dict[str, Any]:
    """Connect (retrying while the server starts), subscribe to every channel, and collect
    (topic, log time, payload) until the server goes away."""
    while True:
        try:
            ws = await websockets.connect(f"ws://127.0.0.1:{port}",
                                          subprotocols=["foxglove.sdk.v1"])
            break
        except OSError:
            if time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.05)
    channels: dict[int, dict[str, Any]] = {}
    got: list[tuple[str, int, bytes]] = []
    info: dict[str, Any] = {}
    subs: dict[int, int] = {}  # subscription id -> channel id
    try:
        async for raw in ws:
            if isinstance(raw, str):
                m = json.loads(raw)
                if m["op"] == "serverInfo":
                    info = m
                elif m["op"] == "advertise":
                    new = [c for c in m["channels"] if c["id"] not in channels]
                    channels |= {c["id"]: c for c in new}
                    for c in new:
                        subs[len(subs) + 1] = c["id"]
                    await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                        {"id": sid, "channelId": cid} for sid, cid in subs.items()
                        if cid in {c["id"] for c in new}]}))
            elif raw[0] == 1:  # message data: subscription id, log time, payload
                sid, t_ns = struct.unpack_from("<IQ", raw, 1)
                got.append((channels[subs[sid]]["topic"], t_ns, raw[13:]))
            if time.monotonic() > deadline:
                break
    except websockets.ConnectionClosed:
        pass
    return {"info": info, "channels": channels, "messages": got}


def test_live_run_serves_channels_and_messages(tmp_path: Path) -> None:
    port = _free_port()
    (tmp_path / "baselines").mkdir()
    proc = subprocess.Popen(
        [sys.executable, "-m", "kartci.cli", "run", "line_straight", "--set", "duration_s=3",
         "--set", "criteria={}", "--set", "metrics.line_tracking.transient_s=1", "--live",
         "--live-port", str(port), "--out", tmp_path / "out",
         "--baselines", tmp_path / "baselines", "--no-strict"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        seen = asyncio.run(_client(port, time.monotonic() + 60))
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    assert f"live: ws://127.0.0.1:{port}" in err
    assert seen["info"]["name"] == "kartci"
    by_topic = {c["topic"]: c for c in seen["channels"].values()}
    assert {"/lt0/odom", "/lt0/line_sensor", "/lt0/wheel_cmd", "/tf_static",
            "/lt0/robot_description", "/kartci/scenario"} <= set(by_topic)
    odom = by_topic["/lt0/odom"]
    assert (odom["encoding"], odom["schemaName"], odom["schemaEncoding"]) == (
        "cdr", "nav_msgs/msg/Odometry", "ros2msg")
    topics = [t for t, _, _ in seen["messages"]]
    assert "/tf_static" in topics and "/lt0/robot_description" in topics  # latched: resent
    store = typestore()
    odoms = [(t, store.deserialize_cdr(data, "nav_msgs/msg/Odometry"))
             for topic, t, data in seen["messages"] if topic == "/lt0/odom"]
    assert len(odoms) > 20  # a run's worth, not one message
    times = [t for t, _ in odoms]
    assert times == sorted(times) and times[-1] == 3_000_000_000  # the run's last moment
    assert all(m.child_frame_id == "lt0/base_link" for _, m in odoms)
    # paced to real time: the messages came over about the run's duration
    assert (tmp_path / "out" / "line_straight" / "run.mcap").is_file()  # and it was logged


def test_live_needs_one_run_at_a_time(tmp_path: Path) -> None:
    res = subprocess.run([sys.executable, "-m", "kartci.cli", "run", "line_straight", "--live",
                          "-j", "2", "--out", tmp_path / "out"], capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 2
    assert res.stderr.strip().splitlines()[-1].startswith("kartci: error: --live serves one run")
