"""The bridge's Zenoh configuration: rmw_zenoh's ZENOH_CONFIG_OVERRIDE read as rmw_zenoh reads
it, and nothing beyond this host unless allowed."""

from __future__ import annotations

import pytest

from kartci.bridge.link import beyond_host, is_loopback, open_listening, parse_override
from kartci.bridge.link import session_config as config
from kartci.errors import RunError, SpecError


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
