"""What a report draws for a go-kart run: paths on the track, speed, wheel speeds, obstacles,
MPCC horizons and solve times, read back from the log."""

from __future__ import annotations

import numpy as np
import pandas as pd

from kartci.logs.reader import messages
from kartci.logs.types import yaw_of
from kartci.metrics import recorded_track
from kartci.metrics.kart import kart_track
from kartci.metrics.race import rect
from kartci.metrics.trajectory import Trajectory, TrajectoryError, ape_errors, associate
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
                 obstacles=obstacles, horizons=horizons, solves=solves,
                 estimates=estimates(ctx), detections=detections(ctx))


def estimates(ctx: PlotContext) -> dict[str, pd.DataFrame]:
    """Each agent's localization estimate and its error against the truth (associated)."""
    out = {}
    for agent in ctx.scenario.agents:
        est, ref = ctx.tables.get(f"/{agent}/localization/odom"), ctx.tables.get(
            f"/{agent}/odom")
        if est is None or ref is None or est.empty or ref.empty:
            continue
        try:
            r, e = associate(Trajectory.from_odometry(ref), Trajectory.from_odometry(est))
        except TrajectoryError:
            continue
        out[agent] = pd.DataFrame({"t": e.t_s, "x": e.xyz_m[:, 0], "y": e.xyz_m[:, 1],
                                   "error_m": ape_errors(r, e)})
    return out


def detections(ctx: PlotContext, moments: int = 6) -> dict[str, list[tuple[np.ndarray, bool]]]:
    """Boxes of each agent's detector at a few moments spread over the run."""
    out: dict[str, list[tuple[np.ndarray, bool]]] = {}
    for agent, spec in ctx.scenario.agents.items():
        if "obstacle_detector" not in spec.nodes:
            continue
        frames = [m for _, _, m in messages(ctx.path,
                                            [f"/{agent}/obstacle_detector/detections"])]
        boxes = []
        for k in np.linspace(0, len(frames) - 1, moments).astype(int) if frames else ():
            for d in frames[k].detections:
                c, size = d.bbox.center, d.bbox.size
                boxes.append((rect(c.position.x, c.position.y, size.x, size.y,
                                   yaw_of(c.orientation)),
                              bool(d.results) and d.results[0].hypothesis.class_id ==
                              "dynamic"))
        out[agent] = boxes
    return out
