"""What robot kinds share in the loop: a name, an agent, fixed frames, pose publishing."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kartci.core import Agent
from kartci.errors import RunError
from kartci.sim.body import BodyState
from kartci.sim.messages import (
    WORLD_FRAME,
    odometry,
    quat_from_matrix,
    tf_message,
    transform,
)
from kartci.sim.robot import Put


def every(period_s: float, dt_s: float) -> int:
    """Physics steps per period (at least one)."""
    return max(1, round(period_s / dt_s))


@dataclass
class RobotBase:
    """What robot kinds share: name, agent, control period in physics steps and fixed frames, with
    tf and pose publishing."""

    name: str
    agent: Agent
    ctrl_every: int
    frames: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    def static_tf(self, frames: tuple[str, ...]) -> list[Any]:
        """tf_static of the given fixed frames, relative to base_link."""
        out = []
        for frame in frames:
            rel, rot = self.frames[frame]
            out.append(transform(0, f"{self.name}/base_link", f"{self.name}/{frame}", rel,
                                 quat_from_matrix(rot)))
        return out

    def publish_pose(self, st: BodyState, t_ns: int, put: Put) -> None:
        """Odometry and base_link's tf at `t_ns`; a RunError once the state is not finite (the
        simulation blew up)."""
        if not all(map(math.isfinite, (*st.xyz, *st.v_body))):
            raise RunError(f"agent {self.name}: non-finite state at t={t_ns * 1e-9:.3f} s")
        put("odom", odometry(t_ns, self.name, st), t_ns)
        put("/tf", tf_message([transform(t_ns, WORLD_FRAME, f"{self.name}/base_link", st.xyz,
                                         st.quat)]), t_ns)
