"""What a report draws for a go-kart run: paths on the track, speed, wheel speeds, obstacles,
MPCC horizons and solve times, and the racing diagnostics (laps and sectors, track-limit margin,
the driver's commands), read back from the log."""

from __future__ import annotations

import numpy as np
import pandas as pd

from kartci.logs.reader import messages
from kartci.logs.types import yaw_of
from kartci.metrics import recorded_track
from kartci.metrics.outline import box
from kartci.metrics.progress import crossing_time, kart_track, wheel_margins_m
from kartci.metrics.trajectory import Trajectory, TrajectoryError, ape_errors, associate
from kartci.plotting import (
    Axis,
    Figure,
    FigureContext,
    PlotContext,
    Plots,
    Role,
    Series,
    wheel_series,
)
from kartci.plotting.builders import (
    col,
    controls,
    event_at,
    lap_overlays,
    localization_error,
    margins,
    plane,
    speed_time,
    time_series,
    wheel_speeds,
)
from kartci.robots.gokart.params import GokartModel
from kartci.worlds.track import Track

SECTORS = 3
CONTROLS = ("steering_wheel_angle_rad", "acceleration_mps2", "brake_mps2")


def lap_table(track: Track, tr: pd.DataFrame) -> pd.DataFrame:
    """Each complete lap: its time and the times of its sectors (the track split in three by
    distance), from the same interpolated line crossings as the lap metrics."""
    t, total = tr["t"].to_numpy(), tr["s_total"].to_numpy()
    length = track.length_m
    rows = []
    start = 0.0  # the first lap runs from the start of the run, as `lap_times_s` counts it
    for lap in range(1, int(max(total.max(), 0) // length) + 1):
        marks = [crossing_time(t, total, (lap - 1) * length + k * length / SECTORS)
                 for k in range(1, SECTORS)]
        end = crossing_time(t, total, lap * length)
        # the first lap's first sector starts at the run's start, like its lap time
        edges = [start, *(m if m >= start else start for m in marks), end]
        rows.append({"lap": lap, "time_s": end - start,
                     **{f"s{k + 1}_s": edges[k + 1] - edges[k] for k in range(SECTORS)}})
        start = end
    return pd.DataFrame(rows, columns=["lap", "time_s", *(f"s{k + 1}_s" for k in range(SECTORS))])


def kart_plots(ctx: PlotContext) -> Plots:
    """What a go-kart report draws: paths along the recorded track, wheel speeds, collisions,
    obstacles, a few MPCC horizons and solve times, laps and sectors, margins and commands."""
    t, scenario = ctx.tables, ctx.scenario
    track = recorded_track(t, ctx.path)
    tracks = {a: kart_track(track, odom) for a in scenario.agents
              if (odom := t.get(f"/{a}/odom")) is not None and not odom.empty}
    wheels, commands, collisions = wheel_series(ctx, ("rear_left_wheel_joint",
                                                 "rear_right_wheel_joint"))
    obstacles = [np.asarray(box(b.center_m, b.size_m[0], b.size_m[1], b.yaw_rad))
                 for b in getattr(scenario.world, "obstacles", ())]
    horizons, solves, laps, margins, controls = {}, {}, {}, {}, {}
    for agent in scenario.agents:
        plans = t.get(f"/{agent}/mpcc/horizon")
        if plans is not None and len(plans):  # a few moments, evenly spread
            rows = plans.iloc[np.linspace(0, len(plans) - 1, 8).astype(int)[1:]]
            horizons[agent] = [np.column_stack([np.asarray(x, float), np.asarray(y, float)])
                               for x, y in zip(rows["xs"], rows["ys"], strict=True)]
        stats = t.get(f"/{agent}/mpcc/stats")
        if stats is not None:
            solves[agent] = stats[["t", "solve_ms", "success"]]
        cmd = t.get(f"/{agent}/cmd")
        if cmd is not None and not cmd.empty:
            controls[agent] = cmd[["t", *CONTROLS]].reset_index(drop=True)
        model = scenario.agents[agent].model
        if agent in tracks and isinstance(model, GokartModel):
            tr = tracks[agent]
            laps[agent] = lap_table(track, tr)
            margins[agent] = pd.DataFrame({"t": tr["t"], "margin_m": wheel_margins_m(
                track, tr, np.asarray(model.wheel_xy_m))})
    return Plots("track", track.xy, list(track.bounds()), tracks, wheels, commands, collisions,
                 obstacles=obstacles, laps=laps, track_length_m=track.length_m,
                 margins=margins, controls=controls, estimates=estimates(ctx),
                 detections=detections(ctx), robot="gokart",
                 own={"horizons": horizons, "solves": solves})


def kart_figures(ctx: FigureContext) -> list[Figure]:
    """A kart run's figures: the track seen from above with a few MPCC horizons, laps
    overlaid, speed, commands, margins, localization error, wheel speeds and MPCC solve times;
    failed solves marked on each after the collisions."""
    p = ctx.plots
    solves: dict[str, pd.DataFrame] = p.own.get("solves", {})
    ev = [*ctx.events, *(event_at(p, agent, float(t), "solver failure")
                         for agent, st in sorted(solves.items())
                         for t in col(st[~st["success"].astype(bool)], "t"))]
    horizons: dict[str, list[np.ndarray]] = p.own.get("horizons", {})
    plans = [Series(f"{agent} MPCC horizon {i + 1}", plan[:, 0], plan[:, 1], Role.COMMAND)
             for agent, agent_plans in sorted(horizons.items())
             for i, plan in enumerate(agent_plans)]
    return [plane(p, ev, plans), *lap_overlays(p, ev), speed_time(p, ev), controls(p, ev),
            margins(p, ev), localization_error(p, ev), wheel_speeds(p, ev),
            Figure("solves", "MPCC solve time (wall clock)", "sim time [s]", "solve time [ms]",
                   Axis.TIME, [time_series(a, st, "solve_ms") for a, st in solves.items()], ev,
                   log_y=True)]


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
                boxes.append((np.asarray(box((c.position.x, c.position.y), size.x, size.y,
                                             yaw_of(c.orientation))),
                              bool(d.results) and d.results[0].hypothesis.class_id ==
                              "dynamic"))
        out[agent] = boxes
    return out
