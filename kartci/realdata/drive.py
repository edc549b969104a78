"""A recorded drive as simreal and calibrate use it: the robot's odometry and the commands it
was given, on one clock that starts at the first pose."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kartci.errors import LogError
from kartci.logs import messages, tables
from kartci.realdata.importer import COMMAND_TOPIC

STATE = ("x", "y", "yaw", "vx", "vy", "wz")


@dataclass(frozen=True)
class Drive:
    """Odometry samples (t_s from the first pose; x, y m; yaw rad, unwrapped; vx, vy m/s in the
    body frame; wz rad/s) and the commands, as (t_s, topic relative to the robot, message)."""

    t_s: np.ndarray
    state: np.ndarray  # (N, 6): x, y, yaw, vx, vy, wz
    commands: tuple[tuple[float, str, Any], ...]

    @property
    def duration_s(self) -> float:
        """From the first pose to the last, s."""
        return float(self.t_s[-1])

    def at(self, t_s: float) -> np.ndarray:
        """The state at time t (linear interpolation; yaw is unwrapped)."""
        return np.array([np.interp(t_s, self.t_s, self.state[:, i]) for i in range(6)])


def read_drive(run_log: Path, agent: str) -> Drive:
    """The drive of `agent` in a kartci run log (an imported log, or a simulated run)."""
    odom = tables(run_log, [f"/{agent}/odom"]).get(f"/{agent}/odom")
    if odom is None or len(odom) < 2:
        raise LogError(f"{run_log}: needs odometry of {agent} (/{agent}/odom) to compare with")
    t0 = float(odom["t"].iloc[0])
    state = odom[list(STATE)].to_numpy(dtype=float).copy()
    state[:, 2] = np.unwrap(state[:, 2])
    wanted = sorted({f"/{agent}/{name}" for name in COMMAND_TOPIC.values()})
    cmds = []
    for topic, t_ns, m in messages(run_log, wanted):
        hdr = getattr(m, "header", None)
        stamp = hdr.stamp.sec + hdr.stamp.nanosec * 1e-9 if hdr is not None else t_ns * 1e-9
        cmds.append((stamp - t0, topic.rsplit("/", 1)[1], m))
    if not cmds:
        raise LogError(f"{run_log}: no commands of {agent} to replay ({', '.join(wanted)})")
    cmds.sort(key=lambda c: c[0])
    return Drive(odom["t"].to_numpy(dtype=float) - t0, state, tuple(cmds))
