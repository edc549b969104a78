"""What a report draws for a line-tracker run: the sensor point against the line, its distance
from the line over time, wheel speeds measured and commanded."""

from __future__ import annotations

import numpy as np

from kartci.plotting import (
    Axis,
    Event,
    Figure,
    FigureContext,
    PlotContext,
    Plots,
    Role,
    wheel_series,
)
from kartci.plotting.builders import plane, time_series, wheel_speeds
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
                 commands, collisions, transient, robot="line_tracker")


def tracking_error(p: Plots, ev: list[Event], band_m: float = 0.008) -> Figure:
    """Cross-track error (m) over sim time, the sensor's range marked (and the baseline's)."""
    s = [time_series(f"baseline {a}", ref, "offset", Role.REFERENCE)
         for a, ref in sorted(p.reference.items()) if "offset" in ref]
    s += [time_series(a, tr, "offset") for a, tr in p.tracks.items()]
    note = f", first {p.transient_s:g} s not scored" if p.transient_s > 0 else ""
    return Figure("tracking", f"cross-track error (guides: ±{band_m * 1000:g} mm sensor range"
                  f"{note})", "sim time [s]", "cross-track error [m]", Axis.TIME, s, ev,
                  hlines=(-band_m, band_m))


def line_figures(ctx: FigureContext) -> list[Figure]:
    """A line-tracker run's figures: the sensor point against the line, its cross-track error
    and the wheel speeds."""
    p, ev = ctx.plots, ctx.events
    return [plane(p, ev, what="sensor point"), tracking_error(p, ev), wheel_speeds(p, ev)]
