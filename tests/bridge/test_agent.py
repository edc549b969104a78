"""The bridge agent's own rules, without a stack: which answers count for a tick, how each
command type is applied, and that closing it frees its session."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from kartci import core
from kartci.bridge.agent import ExternalAgent
from kartci.bridge.params import ExternalController
from kartci.core import AgentContext
from kartci.errors import RunError
from kartci.logs.types import header, msg, typestore
from kartci.project import current as active_project
from kartci.scenario import load_scenario


def agent(commands: list[dict[str, str]]) -> ExternalAgent:
    spec = load_scenario("external_pure_pursuit", project=active_project())
    params = ExternalController(commands=commands)  # no program: nothing is started
    built = core.CONTROLLERS.get("external").build(
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


def test_kartci_offers_a_latched_track_in_its_token_and_reads_the_stacks_qos() -> None:
    """The stack's token asks for a transient-local track: kartci's track publisher says
    reliable + transient-local in its own token (rmw_zenoh's QoS field), so rmw_zenoh's graph
    shows the pair as compatible; a best-effort publisher's token is read as best effort (on
    Zenoh its data reaches kartci's subscription whatever the QoS says)."""
    from kartci.bridge import ros2
    from kartci.bridge.lockstep import Durability, Qos, Reliability

    a = agent([{"topic": "/kart0/cmd_vel", "type": "geometry_msgs/msg/Twist"}])
    try:
        stack = ros2.NodeName(0, "f" * 32, 0, "driver")
        latched = ros2.qos_text(Qos(Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 1))
        a._token(ros2.entity_token(stack, 11, ros2.EntityKind.SUBSCRIPTION, "/kartci/track",
                                   "std_msgs/msg/String", latched))
        a._pending.append(("/kartci/track", msg("std_msgs/msg/String", data="x_m,y_m")))
        a.spec = a.spec.model_copy(update={"startup_timeout_s": 0.2})
        with pytest.raises(RunError, match="subscription to /kartci/track never matched"):
            a._declare()  # no real subscriber behind the token: it never matches
        own = str(a.node.session.zid())
        mine = [t for t in a._tokens if "/MP/" in t and "%kartci%track" in t and own in t]
        assert len(mine) == 1
        assert ros2.parse_qos(mine[0].rsplit("/", 1)[1]) == Qos(
            Reliability.RELIABLE, Durability.TRANSIENT_LOCAL, 1)
        best_effort = ros2.qos_text(Qos(Reliability.BEST_EFFORT, Durability.VOLATILE, 5))
        a._token(ros2.entity_token(stack, 12, ros2.EntityKind.PUBLISHER, "/kart0/cmd_vel",
                                   "geometry_msgs/msg/Twist", best_effort))
        [driver_pub] = [e for e in a._stack_endpoints() if e.topic == "/kart0/cmd_vel"]
        assert driver_pub.node == "/driver" and not driver_pub.qos.reliable
    finally:
        a.close()
