"""What a report draws for a go-kart run: paths on the track, speed, wheel speeds, obstacles,
MPCC horizons and solve times, read back from the log."""

from __future__ import annotations

import numpy as np

from kartci.metrics import recorded_track
from kartci.metrics.kart import kart_track
from kartci.metrics.race import rect
from kartci.report.data import PlotContext, wheel_series
from kartci.results import Plots


def kart_plots(ctx: PlotContext) -> Plots:
    """What a go-kart report draws: paths along the recorded track, wheel speeds, collisions,
    obstacles, a few MPCC horizons and solve times."""
    t, scenario = ctx.tables, ctx.scenario
    track = recorded_track(t, ctx.path)
    tracks = {a: kart_track(track, odom) for a in scenario.agents
              if (odom := t.get(f"/{a}/odom")) is not None and not odom.empty}
    wheels, commands, collisions = wheel_series(ctx, ("rear_left_wheel_joint",
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
