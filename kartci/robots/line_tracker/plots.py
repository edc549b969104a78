"""What a report draws for a line-tracker run: the sensor point against the line, its distance
from the line over time, wheel speeds measured and commanded."""

from __future__ import annotations

import numpy as np

from kartci.figures import PlotContext, Plots, wheel_series
from kartci.robots.line_tracker.metrics import LineMetricsParams, sensor_track
from kartci.robots.line_tracker.params import line_parts


def line_plots(ctx: PlotContext) -> Plots:
    """What a line-tracker report draws: the sensor point against the line, its cross-track error,
    wheel speeds, and the unscored transient."""
    scenario = ctx.scenario
    tracks = {}
    for agent in scenario.agents:
        odom = ctx.tables.get(f"/{agent}/odom")
        if odom is not None and not odom.empty:
            tr = sensor_track(scenario, agent, odom)
            tracks[agent] = tr.assign(speed=tr["vx"])
    wheels, commands, collisions = wheel_series(ctx, ("left_wheel_hinge", "right_wheel_hinge"))
    world, _ = line_parts(scenario, next(iter(scenario.agents)))
    params = scenario.metrics.get("line_tracking")
    transient = (params if isinstance(params, LineMetricsParams)
                 else LineMetricsParams()).transient_s
    return Plots("line", np.asarray(world.course.polyline(400)), [], tracks, wheels,
                 commands, collisions, transient)
