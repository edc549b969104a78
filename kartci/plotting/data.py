"""Figure data: what a run's figures draw (`Plots`, read back from its log) and what a robot
kind's `plots` function reads to make them (`PlotContext`, see `kartci.core.RobotKind`).
Neutral value types below everything that makes or reads them: the robot kinds and real-data
import draw into Plots, the judge keeps a baseline's reference trace from them, the reports
render them."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd

if TYPE_CHECKING:  # field types only: a PlotContext carries a scenario, nothing here calls spec
    import numpy as np

    from kartci.scenario import Scenario


@dataclass(frozen=True)
class Plots:
    """Time series and geometry a report draws; all read back from the run log."""

    kind: str  # the course: "line" (a line lab) or "track" (a race track)
    course: np.ndarray  # (n, 2) line axis or track centreline, m
    edges: list[np.ndarray]  # track bounds (left, right), empty for a line
    tracks: dict[str, pd.DataFrame]  # agent -> t, x, y, offset, speed (+ line: progress)
    wheels: dict[str, pd.DataFrame]  # agent -> t, left, right (measured, rad/s)
    commands: dict[str, pd.DataFrame]  # agent -> t, left, right (commanded, rad/s)
    collisions: dict[str, pd.DataFrame]  # agent -> t, x, y, other, impulse_ns
    transient_s: float = 0.0  # start-up transient the metrics leave out
    obstacles: list[np.ndarray] = field(default_factory=list)  # (4, 2) box footprints, m
    # agent -> t, x, y (localization estimate), error_m (APE translation against the truth)
    estimates: dict[str, pd.DataFrame] = field(default_factory=dict)
    # agent -> detected boxes at a few moments: (4, 2) footprint, m, and whether dynamic
    detections: dict[str, list[tuple[np.ndarray, bool]]] = field(default_factory=dict)
    # racing diagnostics (track kind): complete laps with their three sector times, the distance
    # from the nearest wheel to a track edge (negative: outside), the driver's commands
    laps: dict[str, pd.DataFrame] = field(default_factory=dict)  # agent -> lap, time_s, s1..s3
    track_length_m: float = 0.0
    margins: dict[str, pd.DataFrame] = field(default_factory=dict)  # agent -> t, margin_m
    controls: dict[str, pd.DataFrame] = field(default_factory=dict)  # agent -> t, named columns
    # the baseline's decimated reference trace (kartci.verdict.trace): agent -> t, x, y, speed...
    reference: dict[str, pd.DataFrame] = field(default_factory=dict)
    # the robot kind whose `figures` draw these (empty: the kind-neutral figures)
    robot: str = ""
    # what only that kind's figures read, by name: each an agent -> data mapping
    own: dict[str, dict[str, Any]] = field(default_factory=dict)


@dataclass(frozen=True)
class PlotContext:
    """What a robot kind's `plots` function reads: the scenario, the run log's tables, and the log's
    path (for messages)."""

    scenario: Scenario
    tables: Mapping[str, pd.DataFrame]
    path: Path


def wheel_series(ctx: PlotContext, joints: tuple[str, str]) -> tuple[dict[str, pd.DataFrame], ...]:
    """Measured and commanded speeds of the wheels `joints` (left, right) and collisions of
    every agent."""
    t = ctx.tables
    wheels, commands, collisions = {}, {}, {}
    for agent in ctx.scenario.agents:
        js = _wheel_speeds(t.get(f"/{agent}/joint_states"), joints)
        if js is not None:
            wheels[agent] = js
        cmd = _wheel_speeds(t.get(f"/{agent}/wheel_cmd"), joints)
        if cmd is not None:
            commands[agent] = cmd
        col = t.get(f"/{agent}/collision")
        if col is not None:
            collisions[agent] = col
    return wheels, commands, collisions


def _wheel_speeds(table: pd.DataFrame | None, joints: tuple[str, str]) -> pd.DataFrame | None:
    """Left and right speeds over time from a JointState table; None when its messages do not
    name both joints (an agent may send its speeds unnamed, in order: nothing to attribute)."""
    left, right = (f"{j}.velocity" for j in joints)
    if table is None or left not in table or right not in table:
        return None
    return pd.DataFrame({"t": table["t"], "left": table[left], "right": table[right]})


def overlay(base: Plots | None, head: Plots | None) -> Plots | None:
    """Both runs in one set of plots: every series keyed `base <agent>` / `head <agent>`, drawn
    on head's course (or base's when head has none)."""
    if base is None or head is None:
        return head or base

    def both(field_name: str) -> dict[str, pd.DataFrame]:
        return {f"{who} {agent}": frame for who, p in (("base", base), ("head", head))
                for agent, frame in getattr(p, field_name).items()}

    own = {name: {f"{who} {agent}": data for who, p in (("base", base), ("head", head))
                  for agent, data in p.own.get(name, {}).items()}
           for name in dict.fromkeys([*base.own, *head.own])}
    return replace(head, tracks=both("tracks"), wheels=both("wheels"),
                   commands=both("commands"), collisions=both("collisions"),
                   laps=both("laps"), margins=both("margins"), controls=both("controls"),
                   reference={}, own=own)
