"""Shared pieces of what robot kinds draw in reports (their `plots` entry, see
`kartci.plugins.RobotKind`): the context they get and the wheel-speed series."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from kartci.spec import Scenario


@dataclass(frozen=True)
class PlotContext:
    """What a robot kind's `plots` function reads: the scenario, the run log's tables, and the log's
    path (for messages)."""

    scenario: Scenario
    tables: Mapping[str, pd.DataFrame]
    path: Path


def wheel_series(ctx: PlotContext, joints: tuple[str, str]) -> tuple[dict[str, pd.DataFrame], ...]:
    """Measured and commanded wheel speeds and collisions of every agent."""
    t = ctx.tables
    wheels, commands, collisions = {}, {}, {}
    for agent in ctx.scenario.agents:
        js = t.get(f"/{agent}/joint_states")
        if js is not None:
            wheels[agent] = pd.DataFrame({"t": js["t"], "left": js[f"{joints[0]}.velocity"],
                                          "right": js[f"{joints[1]}.velocity"]})
        cmd = t.get(f"/{agent}/wheel_cmd")
        if cmd is not None:
            commands[agent] = pd.DataFrame({"t": cmd["t"],
                                            "left": cmd["left_wheel_hinge.velocity"],
                                            "right": cmd["right_wheel_hinge.velocity"]})
        col = t.get(f"/{agent}/collision")
        if col is not None:
            collisions[agent] = col
    return wheels, commands, collisions
