"""The bridge's Zenoh configuration: rmw_zenoh's ZENOH_CONFIG_OVERRIDE read as rmw_zenoh reads
it, and nothing beyond this host unless allowed; what one published sample carries."""

from __future__ import annotations

import json
import queue
import struct
import time
from typing import Any

import pytest
import xxhash
import zenoh

from kartci.bridge import ros2
from kartci.bridge.link import Node, beyond_host, is_loopback, open_listening, parse_override
from kartci.bridge.link import session_config as config
from kartci.errors import RunError, SpecError
from kartci.logs.types import header, msg


def test_override_is_key_equals_json5_separated_by_semicolons() -> None:
    text = 'mode="client"; connect/endpoints=["tcp/127.0.0.1:7447"];;'
    assert parse_override(text) == [("mode", '"client"'),
                                    ("connect/endpoints", '["tcp/127.0.0.1:7447"]')]
    assert parse_override("") == []
    with pytest.raises(SpecError, match=r"ZENOH_CONFIG_OVERRIDE: 'mode' is not key=value"):
        parse_override("mode")
    with pytest.raises(SpecError, match="ZENOH_CONFIG_OVERRIDE: cannot set mode to 42"):
        config([], [], False, "mode=42")


@pytest.mark.parametrize(("endpoint", "local"), [
    ("tcp/127.0.0.1:7447", True), ("tcp/127.8.0.1:7447", True), ("tcp/localhost:7447", True),
    ("tcp/[::1]:7447", True), ("udp/127.0.0.1:7447#iface=lo", True),
    ("tcp/0.0.0.0:7447", False), ("tcp/192.168.1.5:7447", False), ("tcp/[::]:7447", False),
    ("tcp/robot.local:7447", False)])
def test_loopback_endpoints(endpoint: str, local: bool) -> None:
    assert is_loopback(endpoint) is local


def test_what_reaches_beyond_this_host() -> None:
    ep = "tcp/127.0.0.1:7447"
    assert beyond_host(config([ep], [ep], False)) == []
    assert beyond_host(config([ep], [], True)) == []
    assert beyond_host(config([ep], [], False,
                              'connect/endpoints=["tcp/10.0.0.2:7447"];'
                              "scouting/multicast/enabled=true")) == [
        "tcp/10.0.0.2:7447", "multicast scouting"]
    assert beyond_host(config([ep], [], False,
                              'listen/endpoints={router: ["tcp/0.0.0.0:7447"]}')) == [
        "tcp/0.0.0.0:7447"]


def test_the_override_and_connect_are_refused_beyond_this_host_unless_allowed(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("ZENOH_CONFIG_OVERRIDE", 'connect/endpoints=["tcp/192.0.2.1:7447"]')
    with pytest.raises(SpecError, match=r"^bridge: tcp/192\.0\.2\.1:7447 reaches beyond this "
                       "host; set allow_remote: true in the external controller to allow it$"):
        open_listening()
    monkeypatch.delenv("ZENOH_CONFIG_OVERRIDE")
    with pytest.raises(SpecError, match=r"tcp/0\.0\.0\.0:7447 reaches beyond this host"):
        open_listening(connect=("tcp/0.0.0.0:7447",))


def test_a_router_to_join_must_be_there() -> None:
    from kartci.bridge.link import free_port

    absent = f"tcp/127.0.0.1:{free_port()}"
    with pytest.raises(RunError, match=f"bridge: cannot listen on tcp/127.0.0.1:<free port> "
                       f"and connect to {absent} "):
        open_listening(connect=(absent,))


def test_a_published_range_has_jazzys_key_and_layout_and_rmw_zenohs_gid() -> None:
    """kartci's node publishes the line tracker's sonar for a Jazzy stack; a plain Zenoh peer
    subscribed to the key written out by hand gets Jazzy's 48-byte Range (variance last) and an
    attachment whose GID is XXH3-128 of the publisher's liveliness token, as rmw_zenoh's."""
    session, endpoint = open_listening()
    node = Node(session, 0, "kartci", ros2.Distro.JAZZY)
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("listen/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    peer = zenoh.open(conf)
    try:
        samples: queue.Queue[Any] = queue.Queue()
        tokens: list[str] = []
        _keep = [peer.declare_subscriber(
                    "0/lt0/sonar/sensor_msgs::msg::dds_::Range_/RIHS01_b42b62562e93cbfe9d42b82fe"
                    "5994dfa3d63d7d5c90a317981703f7388adff3a", samples.put),
                peer.liveliness().declare_subscriber(
                    "@ros2_lv/**", lambda s: tokens.append(str(s.key_expr)), history=True)]
        pub = node.publisher("/lt0/sonar", "sensor_msgs/msg/Range")
        deadline = time.monotonic() + 10.0
        while not (pub.matched() and any("/MP/" in t for t in tokens)):
            assert time.monotonic() < deadline, "the subscriber never matched"
            time.sleep(0.01)
        pub.put(ros2.serialize(msg("sensor_msgs/msg/Range", header=header(0, "lt0/sonar"),
                                   radiation_type=0, field_of_view=0.5, min_range=0.02,
                                   max_range=4.0, range=1.25), ros2.Distro.JAZZY))
        sample = samples.get(timeout=10.0)
        payload, raw = sample.payload.to_bytes(), sample.attachment.to_bytes()
        [token] = [t for t in tokens if "/MP/" in t]
    finally:
        peer.close()  # type: ignore[no-untyped-call]
        node.close()
    assert token == (f"@ros2_lv/0/{session.zid()}/0/11/MP/%/%/kartci/%lt0%sonar/"
                     "sensor_msgs::msg::dds_::Range_/RIHS01_b42b62562e93cbfe9d42b82fe5994dfa3d63"
                     "d7d5c90a317981703f7388adff3a/::,10:,:,:,,")
    assert len(payload) == 48 and payload[-4:] == struct.pack("<f", 0.0)
    h = xxhash.xxh3_128_intdigest(token.encode())
    assert raw[:8] == struct.pack("<q", 1) and raw[16] == 16
    assert raw[17:] == struct.pack("<QQ", h & (2**64 - 1), h >> 64)
