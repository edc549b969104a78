"""Synthetic "real" logs with known truth: the simulated robot with deliberately changed
parameters, driven by a fixed exciting command sequence, its odometry noised. Tests and
benchmarks use them where no real log of the robot exists (no public go-kart log does)."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from kartci import core
from kartci.logs import McapLogWriter, header, messages, msg, open_log
from kartci.logs.types import for_writing
from kartci.project import Project
from kartci.realdata.plant import diff_drive
from kartci.realdata.profile import CommandRole
from kartci.scenario import load_scenario
from kartci.sim.session import Session

# (hold time s, speed m/s, front-wheel angle rad): steps in speed and steering excite the
# speed loop, the steering rate and the speed scale (kart)
KART_STEPS = ((1.0, 3.0, 0.0), (0.8, 5.0, 0.25), (0.8, 5.0, -0.25), (0.7, 2.5, 0.3),
              (0.9, 6.0, -0.15), (0.6, 3.5, 0.3), (0.8, 5.5, 0.0), (0.7, 2.0, -0.3))
BASE = CommandRole(topic="cmd_vel")  # the base controller's kinematics: the line tracker's
# (hold time s, forward m/s, turn rad/s): a differential drive
DIFF_STEPS = ((1.0, 0.15, 0.0), (0.8, 0.25, 1.0), (0.8, 0.1, -1.5), (0.9, 0.3, 0.5),
              (0.7, 0.2, -0.8))


class Exciter:
    """Publishes a repeating step sequence: AckermannDriveStamped (`ackermann_cmd`) for a kart,
    Twist (`cmd_vel`) for a differential drive."""

    inputs: tuple[str, ...] = ()

    def __init__(self, diff_drive: bool, period_s: float = 0.02) -> None:
        self.period_s, self.diff = period_s, diff_drive
        self.steps = DIFF_STEPS if diff_drive else KART_STEPS
        self.cycle_s = sum(s[0] for s in self.steps)

    def on_message(self, topic: str, message: Any) -> None:
        """Reads nothing."""

    def command(self, t_s: float) -> tuple[float, float]:
        """(speed or forward velocity, steering angle or turn rate) at time t."""
        t = t_s % self.cycle_s
        for hold, a, b in self.steps:
            if t < hold:
                return a, b
            t -= hold
        return self.steps[-1][1], self.steps[-1][2]

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        """The command at this tick."""
        a, b = self.command(t_ns * 1e-9)
        if self.diff:  # the Twist, and the wheel speeds a base controller makes of it
            vec = "geometry_msgs/msg/Vector3"
            twist = msg("geometry_msgs/msg/Twist", linear=msg(vec, x=a, y=0.0, z=0.0),
                        angular=msg(vec, x=0.0, y=0.0, z=b))
            return [("cmd_vel", twist), *diff_drive(BASE)("cmd_vel", twist, t_ns)]
        drive = msg("ackermann_msgs/msg/AckermannDrive", steering_angle=b,
                    steering_angle_velocity=0.0, speed=a, acceleration=0.0, jerk=0.0)
        return [("ackermann_cmd", msg("ackermann_msgs/msg/AckermannDriveStamped",
                                      header=header(t_ns, "base_link"), drive=drive))]


def synthetic_log(scenario: str, overrides: Sequence[str], duration_s: float, dst: Path,
                  proj: Project, noise_m: float = 0.005, noise_rad: float = 0.003,
                  seed: int = 0) -> Path:
    """Run `scenario` (one agent) with `overrides` (the changed parameters) under the exciter
    for `duration_s`, and write its log to `dst` with Gaussian noise on the odometry's pose
    (`noise_m` on x and y, `noise_rad` on yaw) and twist (a tenth of those, per second)."""
    spec = load_scenario(scenario, [*overrides, f"duration_s={duration_s}"], project=proj)
    agent = next(iter(spec.agents))
    replay = core.ROBOTS.get(spec.agents[agent].model.kind).simreal
    diff = replay is not None and replay.wheel_speeds
    rng = np.random.default_rng(seed)
    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "raw.mcap"
        with Session(spec, raw, agents={agent: Exciter(diff)}) as session:
            r = session.reset()
            while not r.done:
                r = session.step()
        with open_log(raw) as log:
            store = for_writing(log.typestore)
        with McapLogWriter(dst, store) as out:
            for topic, t_ns, m in messages(raw):
                if topic == f"/{agent}/odom":
                    _noise(m, rng, noise_m, noise_rad)
                out.write(topic, m, t_ns)
    return dst


def _noise(m: Any, rng: np.random.Generator, noise_m: float, noise_rad: float) -> None:
    p, q = m.pose.pose.position, m.pose.pose.orientation
    p.x += noise_m * float(rng.standard_normal())
    p.y += noise_m * float(rng.standard_normal())
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
    yaw += noise_rad * float(rng.standard_normal())
    q.x, q.y, q.z, q.w = 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)
    tw = m.twist.twist
    tw.linear.x += noise_m * 10 * float(rng.standard_normal())
    tw.angular.z += noise_rad * 10 * float(rng.standard_normal())
