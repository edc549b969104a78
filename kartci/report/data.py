"""What a report draws for each built-in robot kind, read back from a run's log: the robot
kind's `plots` entry (see `kartci.plugins.RobotKind`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from kartci import geometry
from kartci.metrics import recorded_track
from kartci.metrics.kart import kart_track
from kartci.metrics.line import sensor_track
from kartci.metrics.race import rect
from kartci.results import Plots
from kartci.spec import Scenario
from kartci.spec.models import LineMetricsParams, line_parts


@dataclass(frozen=True)
class PlotContext:
    scenario: Scenario
    tables: Mapping[str, pd.DataFrame]
    path: Path


def _series(ctx: PlotContext, joints: tuple[str, str]) -> tuple[dict[str, pd.DataFrame], ...]:
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


def kart_plots(ctx: PlotContext) -> Plots:
    t, scenario = ctx.tables, ctx.scenario
    track = recorded_track(t, ctx.path)
    tracks = {a: kart_track(track, odom) for a in scenario.agents
              if (odom := t.get(f"/{a}/odom")) is not None and not odom.empty}
    wheels, commands, collisions = _series(ctx, ("rear_left_wheel_joint",
                                                 "rear_right_wheel_joint"))
    obstacles = [rect(b.center_m[0], b.center_m[1], b.size_m[0], b.size_m[1], b.yaw_rad)
                 for b in getattr(scenario.world, "obstacles", ())]
    horizons, solves = {}, {}
    for agent in scenario.agents:
        plans = t.get(f"/{agent}/mpcc/horizon")
        if plans is not None and len(plans):  # a few moments, evenly spread
            rows = plans.iloc[np.linspace(0, len(plans) - 1, 8).astype(int)[1:]]
            horizons[agent] = [np.column_stack([np.asarray(x, float), np.asarray(y, float)])
                               for x, y in zip(rows["xs"], rows["ys"], strict=True)]
        stats = t.get(f"/{agent}/mpcc/stats")
        if stats is not None:
            solves[agent] = stats[["t", "solve_ms", "success"]]
    return Plots("track", track.xy, list(track.bounds()), tracks, wheels, commands, collisions,
                 obstacles=obstacles, horizons=horizons, solves=solves)


def line_plots(ctx: PlotContext) -> Plots:
    scenario = ctx.scenario
    tracks = {}
    for agent in scenario.agents:
        odom = ctx.tables.get(f"/{agent}/odom")
        if odom is not None and not odom.empty:
            tr = sensor_track(scenario, agent, odom)
            tracks[agent] = tr.assign(speed=tr["vx"])
    wheels, commands, collisions = _series(ctx, ("left_wheel_hinge", "right_wheel_hinge"))
    world, _ = line_parts(scenario, next(iter(scenario.agents)))
    params = scenario.metrics.get("line_tracking")
    transient = (params if isinstance(params, LineMetricsParams)
                 else LineMetricsParams()).transient_s
    return Plots("line", np.asarray(geometry.polyline(world.course, 400)), [], tracks, wheels,
                 commands, collisions, transient)
