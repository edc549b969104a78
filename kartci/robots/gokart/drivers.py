"""Go-kart agents: the manual agent (joystick log), command-stream playback, a command script,
and a scripted driver that produces joystick messages (pure pursuit on the centreline)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from kartci.core import AgentContext, ControllerParams, Outbox
from kartci.logs.recorded import COMMANDS, JOY, Recorded
from kartci.logs.types import base_link, header, typestore, yaw_of
from kartci.robots.gokart import KartInput, axle_distance_m, column_for_wheel_angle, speed_to_pedals
from kartci.robots.gokart.controllers import (
    CommandsController,
    JoyDriverController,
    ManualController,
    ScriptController,
)
from kartci.robots.gokart.joy import (
    check_counts,
    check_pad,
    kart_command,
    load_mapping,
    model_folders,
    to_command,
    to_joy,
)
from kartci.robots.gokart.params import GokartModel
from kartci.scenario.models import LogSource
from kartci.worlds.track import TRACK_TOPIC, Track, track_from_text


def _kart(ctx: AgentContext) -> GokartModel:
    assert isinstance(ctx.model, GokartModel)  # Controller.build checked the robot kind
    return ctx.model


class ManualAgent:
    """Joy messages from a log, through a controller mapping, to kart commands. The Joy stream
    is republished on the agent's namespace so the run log holds what the driver did."""

    inputs: tuple[str, ...] = ()

    def __init__(self, spec: ManualController, ctx: AgentContext) -> None:
        self.period_s, self.model = spec.period_s, _kart(ctx)
        self.frame = base_link(ctx.name)
        self.mapping = load_mapping(spec.mapping, model_folders(ctx))
        self.source = Recorded(spec.source, JOY)
        check_counts(self.mapping, spec.mapping, self.source.msgs[0],
                     f"{self.source.path} {self.source.topic}", model_folders(ctx))
        self._last = -1

    def on_message(self, topic: str, message: Any) -> None:
        """Nothing to read: the joystick stream comes from the log."""

    def step(self, t_ns: int) -> Outbox:
        """Republish the Joy messages recorded since the last tick and command the kart from the
        latest one (a zero command before the log's first message)."""
        i = self.source.index(t_ns)
        if i < 0:
            return [("cmd", kart_command(KartInput(), t_ns, self.frame))]
        joy = self.source.msgs[i]
        out: Outbox = []
        joy_type = typestore().types["sensor_msgs/msg/Joy"]  # header, axes, buttons
        for j in range(self._last + 1, i + 1):  # every message since the last step, re-stamped
            m = self.source.msgs[j]
            out.append(("joy", joy_type(header(self.source.times[j], m.header.frame_id), m.axes,
                                        m.buttons)))
        self._last = i
        return [*out, ("cmd", kart_command(to_command(self.mapping, self.model, joy), t_ns,
                                           self.frame))]


class CommandsAgent:
    """A recorded AckermannDriveStamped, Twist or TwistStamped stream, republished (stamped with
    sim time) on the robot's standard command topic: `ackermann_cmd` or `cmd_vel`. The robot's
    drive-by-wire turns it into steering and pedals, as it would for a team's controller."""

    inputs: tuple[str, ...] = ()

    def __init__(self, spec: CommandsController, ctx: AgentContext) -> None:
        self.period_s, self.frame = spec.period_s, base_link(ctx.name)
        self.source = Recorded(spec.source, COMMANDS)
        self.topic = "ackermann_cmd" if self.source.msgtype.startswith("ackermann") else (
            "cmd_vel")

    def on_message(self, topic: str, message: Any) -> None:
        """Nothing to read: the commands come from the log."""

    def step(self, t_ns: int) -> Outbox:
        """The latest recorded command, restamped with sim time when it has a header; nothing before
        the log's first one."""
        m = self.source.at(t_ns)
        if m is None:
            return []
        if hasattr(m, "header"):
            m = replace(m, header=header(t_ns, self.frame))
        return [(self.topic, m)]


class ScriptAgent:
    """Open-loop kart commands from timed steps: each holds from its `t_s` until the next one's."""

    inputs: tuple[str, ...] = ()

    def __init__(self, spec: ScriptController, ctx: AgentContext) -> None:
        self.steps = sorted(spec.steps, key=lambda s: s.t_s)
        self.period_s, self.frame = spec.period_s, base_link(ctx.name)

    def on_message(self, topic: str, message: Any) -> None:
        """Nothing to read: the script is open loop."""

    def step(self, t_ns: int) -> Outbox:
        """The command of the latest step that is due (the first step before any is)."""
        current = self.steps[0]
        for s in self.steps:
            if s.t_s * 1e9 <= t_ns:
                current = s
        cmd = KartInput(current.steering_rad, current.accel_mps2, current.brake_mps2)
        return [("cmd", kart_command(cmd, t_ns, self.frame))]


class JoyDriver:
    """A driver that steers by pure pursuit on the centreline and sets its speed from the
    curvature ahead, and who only touches the joystick: its Joy messages go through the same
    mapping as the manual agent's, so replaying them reproduces the drive."""

    inputs: tuple[str, ...] = ("odom", TRACK_TOPIC)

    def __init__(self, spec: JoyDriverController, ctx: AgentContext) -> None:
        self.spec, self.model, self.period_s = spec, _kart(ctx), spec.period_s
        self.frame = base_link(ctx.name)
        self.mapping = load_mapping(spec.mapping, model_folders(ctx))
        self._pose: tuple[float, float, float, float] | None = None
        self.track: Track | None = None

    def on_message(self, topic: str, message: Any) -> None:
        """Keep the track (from its CSV text), and the pose and forward speed from odometry."""
        if topic == TRACK_TOPIC:
            self.track = track_from_text(message.data, TRACK_TOPIC)
        elif topic == "odom":
            p, q = message.pose.pose.position, message.pose.pose.orientation
            yaw = yaw_of(q)
            self._pose = (p.x, p.y, yaw, float(message.twist.twist.linear.x))

    def step(self, t_ns: int) -> Outbox:
        """The Joy message for the steering and pedals pure pursuit wants, and the kart command the
        mapping makes of it; nothing until the track and a pose have arrived."""
        if self._pose is None or self.track is None:
            return []
        x, y, yaw, v = self._pose
        sp = self.spec
        s, _, _, _ = self.track.project(np.array([[x, y]]))
        gx, gy, _ = self.track.pose_at(float(s[0]) + sp.lookahead_m, sp.lateral_offset_m)
        alpha = math.atan2(gy - y, gx - x) - yaw
        lw = axle_distance_m(self.model)
        delta = math.atan2(2 * lw * math.sin(alpha), sp.lookahead_m)
        ahead = (self.track.s - s[0]) % self.track.length_m < max(8.0, 2 * v)
        kappa = float(np.abs(self.track.curvature[ahead]).max(initial=1e-3))
        v_target = min(sp.target_speed_mps, math.sqrt(sp.max_lateral_accel_mps2 / kappa))
        accel, brake, _ = speed_to_pedals(v_target, v, 2.0)
        wish = KartInput(column_for_wheel_angle(self.model, delta), accel, brake)
        joy = to_joy(self.mapping, self.model, wish, t_ns, "joy")
        cmd = to_command(self.mapping, self.model, joy)
        return [("joy", joy), ("cmd", kart_command(cmd, t_ns, self.frame))]


def replay(log: Path, topic: str, msgtype: str, mapping: str, models: tuple[Path, ...]
           ) -> ControllerParams:
    """The kart's `RobotKind.replay` (`kartci replay`): a Joy stream drives it through
    `mapping`, whose axis and button counts the log's pad must have; a command stream is
    republished on its standard command topic."""
    source = LogSource(log=str(log.resolve()), topic=topic)
    if msgtype in JOY:
        check_pad(load_mapping(mapping, models), mapping, log, topic, models)
        return ManualController(mapping=mapping, source=source)
    return CommandsController(source=source)
