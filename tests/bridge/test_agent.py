"""The bridge agent's own rules, without a stack: which answers count for a tick, how each
command type is applied, and that closing it frees its session."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from kartci import plugins
from kartci.bridge.agent import ExternalAgent
from kartci.bridge.params import ExternalController
from kartci.errors import RunError
from kartci.logs.types import header, msg, typestore
from kartci.plugins import AgentContext
from kartci.scenario import load_scenario


def agent(commands: list[dict[str, str]]) -> ExternalAgent:
    spec = load_scenario("external_pure_pursuit")
    params = ExternalController(commands=commands)  # no program: nothing is started
    built = plugins.CONTROLLERS.get("external").build(
        params, AgentContext("kart0", spec.agents["kart0"].model))
    assert isinstance(built, ExternalAgent)
    return built


def cdr(m: Any) -> bytes:
    return bytes(typestore().serialize_cdr(m, type(m).__msgtype__))


def ackermann(t_ns: int, speed: float) -> Any:
    return msg("ackermann_msgs/msg/AckermannDriveStamped", header=header(t_ns, "kart0/base_link"),
               drive=msg("ackermann_msgs/msg/AckermannDrive", steering_angle=0.1,
                         steering_angle_velocity=0.0, speed=speed, acceleration=0.0, jerk=0.0))


def test_only_answers_stamped_with_the_tick_count() -> None:
    a = agent([{"topic": "ackermann_cmd", "type": "ackermann_msgs/msg/AckermannDriveStamped"}])
    try:
        topic = "/kart0/ackermann_cmd"
        got = a._receive([(topic, cdr(ackermann(20_000_000, 1.0))),
                          (topic, cdr(ackermann(40_000_000, 2.0)))], 40_000_000)
        assert got[topic].drive.speed == 2.0
        assert a._receive([(topic, cdr(ackermann(20_000_000, 1.0)))], 40_000_000) == {}
        assert a._outbox(got) == [("ackermann_cmd", got[topic])]
        with pytest.raises(RunError, match="does not decode"):
            a._receive([(topic, b"\x00\x01\x00\x00\x01")], 0)
    finally:
        a.close()
    assert a.node.session.is_closed()


def test_joy_goes_through_the_mapping_and_twist_needs_no_stamp() -> None:
    a = agent([{"topic": "joy", "type": "sensor_msgs/msg/Joy"},
               {"topic": "/kart0/cmd_vel", "type": "geometry_msgs/msg/Twist"}])
    try:
        joy = msg("sensor_msgs/msg/Joy", header=header(60_000_000, "joy"),
                  axes=np.zeros(8, dtype=np.float32), buttons=np.zeros(13, dtype=np.int32))
        v3 = msg("geometry_msgs/msg/Vector3", x=1.0, y=0.0, z=0.0)
        twist = msg("geometry_msgs/msg/Twist", linear=v3, angular=v3)
        got = a._receive([("/kart0/joy", cdr(joy)), ("/kart0/cmd_vel", cdr(twist))],
                         60_000_000)
        out = a._outbox(got)
        assert [t for t, _ in out] == ["cmd_vel", "joy", "cmd"]
        cmd = out[2][1]
        assert cmd.__msgtype__ == "kartci_msgs/msg/KartCommand"
        assert cmd.header.stamp.nanosec == 60_000_000
    finally:
        a.close()


def test_placeholders_are_replaced_and_other_braces_kept() -> None:
    from kartci.bridge.agent import substitute

    values = {"endpoint": "tcp/127.0.0.1:7447", "namespace": "kart0"}
    assert substitute("--connect={endpoint}", values) == "--connect=tcp/127.0.0.1:7447"
    assert substitute('{"ns": "{namespace}", "x": {}}', values) == '{"ns": "kart0", "x": {}}'
