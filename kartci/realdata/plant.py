"""The simulated robot as a plant: a scenario's world and robot, driven by a recorded drive's
commands, re-initialised from the recorded state at the start of every window.

The robot must offer `reinitialise(x_m, y_m, yaw_rad, v_mps, yaw_rate_radps)` (the go-kart and
the line tracker do). The floor of every world is an infinite plane, so the robot is placed at
the recorded pose itself and the sim's poses compare with the log's directly."""

from __future__ import annotations

import bisect
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from kartci.errors import SpecError
from kartci.logs import header, msg
from kartci.realdata.drive import Drive
from kartci.realdata.profile import CommandRole
from kartci.scenario import Scenario
from kartci.sim.session import build_world

Converter = Callable[[str, Any, int], list[tuple[str, Any]]]


def _clamp(value: float, limit: float | None) -> float:
    return value if limit is None else min(max(value, -limit), limit)


class DiffDrive:
    """Twist -> wheel speeds as a differential-drive base controller does, with the real
    robot's own kinematics (the profile's), so the simulated wheels' radius and separation can
    differ from them and be calibrated; the profile's speed and acceleration limits applied as
    the controller's speed limiter does (clamp the command, then its change per tick). With an
    acceleration limit the command is re-sent every control tick, so the wheels ramp."""

    def __init__(self, role: CommandRole) -> None:
        self.role = role
        self.every_tick = role.max_accel_mps2 is not None or role.max_yaw_accel_radps2 is not None
        self._last: tuple[float, float, int] | None = None  # v m/s, w rad/s, t ns

    def reset(self, v_mps: float, w_radps: float) -> None:
        """A new window: the robot moves as recorded; ramps start from there."""
        self._last = (v_mps, w_radps, 0)  # the window's first tick is at sim time 0

    def _limit(self, v: float, w: float, t_ns: int) -> tuple[float, float]:
        r = self.role
        v, w = _clamp(v, r.max_speed_mps), _clamp(w, r.max_yaw_rate_radps)
        if self._last is not None and self.every_tick:
            dt = max(t_ns - self._last[2], 0) * 1e-9
            dv, dw = (None if a is None else a * dt
                      for a in (r.max_accel_mps2, r.max_yaw_accel_radps2))
            v = self._last[0] + _clamp(v - self._last[0], dv)
            w = self._last[1] + _clamp(w - self._last[1], dw)
        self._last = (v, w, t_ns)
        return v, w

    def __call__(self, topic: str, m: Any, t_ns: int) -> list[tuple[str, Any]]:
        """The wheel-speed command of a cmd_vel (nothing for other topics)."""
        if topic != "cmd_vel":
            return []
        tw = m.twist if hasattr(m, "twist") else m
        v, w = float(tw.linear.x), float(tw.angular.z)
        if self.every_tick or self.role.max_speed_mps is not None or (
                self.role.max_yaw_rate_radps is not None):
            v, w = self._limit(v, w, t_ns)
        half = self.role.wheel_separation_m / 2
        speeds = np.array([(v - w * half) / self.role.wheel_radius_m,
                           (v + w * half) / self.role.wheel_radius_m])
        return [("wheel_cmd", msg("sensor_msgs/msg/JointState", header=header(t_ns, "base_link"),
                                  name=["left_wheel_hinge", "right_wheel_hinge"],
                                  position=np.zeros(0), velocity=speeds, effort=np.zeros(0)))]


def diff_drive(role: CommandRole) -> Converter:
    """The converter of a differential drive's Twist commands (DiffDrive)."""
    return DiffDrive(role)


def as_recorded(topic: str, m: Any, t_ns: int) -> list[tuple[str, Any]]:
    """The command as it was recorded (the go-kart understands cmd, ackermann_cmd, cmd_vel)."""
    return [(topic, m)]


class Feeder:
    """An agent that publishes, at each control tick, the latest recorded command (converted
    for the robot); `start(t0_s)` moves it to another window."""

    inputs: tuple[str, ...] = ()

    def __init__(self, drive: Drive, period_s: float, convert: Converter) -> None:
        self.period_s = period_s
        self.times = [c[0] for c in drive.commands]
        self.commands = drive.commands
        self.convert = convert
        self.t0_s = 0.0
        self.last = -1
        self.every_tick = bool(getattr(convert, "every_tick", False))

    def start(self, t0_s: float, speed_mps: float = 0.0, yaw_rate_radps: float = 0.0) -> None:
        """Sim time 0 is now log time `t0_s`, where the robot moves as given."""
        self.t0_s, self.last = t0_s, -1
        reset = getattr(self.convert, "reset", None)
        if reset is not None:
            reset(speed_mps, yaw_rate_radps)

    def on_message(self, topic: str, message: Any) -> None:
        """Reads nothing."""

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        """The newest command at or before this tick, once."""
        i = bisect.bisect_right(self.times, self.t0_s + t_ns * 1e-9 + 1e-9) - 1
        if i < 0 or (i == self.last and not self.every_tick):
            return []
        self.last = i
        _, topic, m = self.commands[i]
        return self.convert(topic, m, t_ns)


class Plant:
    """One world with one robot, run window by window; `close()` frees the simulator."""

    def __init__(self, scenario: Scenario, drive: Drive, convert: Converter) -> None:
        if len(scenario.agents) != 1:
            raise SpecError(f"scenario {scenario.name}: simreal needs exactly one agent")
        agent = next(iter(scenario.agents))
        period = scenario.agents[agent].controller.period_s
        self.feeder = Feeder(drive, period, convert)
        self.world = build_world(scenario, {agent: self.feeder})
        self.robot = self.world.robots[0]
        if not hasattr(self.robot, "reinitialise"):
            self.close()
            raise SpecError(f"robot kind {scenario.agents[agent].model.kind} cannot be "
                            "re-initialised from a recorded state (it has no reinitialise())")
        self.dt_s = scenario.physics.dt_s
        self.drive = drive

    def run(self, t0_s: float, t1_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Simulate from the recorded state at `t0_s` to `t1_s`: the recorded sample times in
        [t0, t1] and the sim's state (x, y, yaw, vx, vy, wz) at each."""
        real = self.drive.at(t0_s)
        robot: Any = self.robot
        robot.reinitialise(real[0], real[1], real[2], math.hypot(real[3], real[4]), real[5])
        self.feeder.start(t0_s, real[3], real[5])
        steps = round((t1_s - t0_s) / self.dt_s)
        out = np.empty((steps + 1, 7))
        out[0] = (0.0, *real[:3], *real[3:])
        dt_ns = round(self.dt_s * 1e9)
        ctrl = robot.ctrl_every
        ignore: Callable[[str, Any, int], None] = _ignore
        for k in range(steps + 1):
            if k % ctrl == 0:
                for topic, m in self.feeder.step(k * dt_ns):
                    robot.apply(topic, m)
            if k == steps:
                break
            robot.pre_step(k)
            self.world.step()
            robot.post_step((k + 1) * dt_ns, ignore)
            robot.sense(k + 1, (k + 1) * dt_ns, ignore)
            st = robot.body.state()
            out[k + 1] = ((k + 1) * self.dt_s, st.xyz[0], st.xyz[1], st.yaw, st.v_body[0],
                          st.v_body[1], st.w_body[2])
        sel = (self.drive.t_s >= t0_s - 1e-9) & (self.drive.t_s <= t1_s + 1e-9)
        t = self.drive.t_s[sel]
        yaw = np.unwrap(out[:, 3])
        yaw += real[2] - yaw[0]  # on the log's unwrapped branch
        cols = [out[:, 1], out[:, 2], yaw, out[:, 4], out[:, 5], out[:, 6]]
        rel = t - t0_s
        return t, np.column_stack([np.interp(rel, out[:, 0], c) for c in cols])

    def close(self) -> None:
        """Free the simulator."""
        self.world.close()


def _ignore(topic: str, m: Any, t_ns: int) -> None:
    """Sensor output is not needed: only the body's state is compared."""
