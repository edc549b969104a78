"""What a report draws for an imported log: the path (on its track, if any) and the speed; for
a simreal log also the sim's paths and speeds over the log's."""

from __future__ import annotations

import numpy as np
import pandas as pd

from kartci.metrics.progress import kart_track
from kartci.plotting import PlotContext, Plots
from kartci.realdata.divergence import SIM_WHOLE, SIM_WINDOWS
from kartci.worlds.track import TRACK_TOPIC, track_from_text


def path_frame(odom: pd.DataFrame, t0: float) -> pd.DataFrame:
    """t (from t0), x, y, speed and a zero offset: a path as the plots draw it."""
    return pd.DataFrame({"t": odom["t"] - t0, "x": odom["x"], "y": odom["y"],
                         "speed": np.hypot(odom["vx"], odom["vy"]), "offset": 0.0})


def _odometry(ctx: PlotContext) -> dict[str, tuple[pd.DataFrame, float]]:
    """Every agent's odometry, and the sim's runs of a simreal log, with the log's first time."""
    out = {}
    for a in ctx.scenario.agents:
        odom = ctx.tables.get(f"/{a}/odom")
        if odom is None or odom.empty:
            continue
        t0 = float(odom["t"].iloc[0])
        out[a] = (odom, t0)
        for topic, label in ((SIM_WHOLE, "sim, whole log"), (SIM_WINDOWS, "sim, windows")):
            sim = ctx.tables.get(f"/{a}/{topic}")
            if sim is not None and not sim.empty:
                out[f"{a} {label}"] = (sim, t0)
    return out


def recorded_plots(ctx: PlotContext) -> Plots:
    """Paths and speeds; drawn on the track when the log holds one, else from the first pose
    (the start marker)."""
    odoms = _odometry(ctx)
    table = ctx.tables.get(TRACK_TOPIC)
    if table is not None and not table.empty:
        track = track_from_text(str(table["data"].iloc[0]), "recorded track")
        tracks = {k: kart_track(track, o.assign(t=o["t"] - t0)) for k, (o, t0) in odoms.items()}
        return Plots("track", track.xy, list(track.bounds()), tracks, {}, {}, {})
    paths = {k: path_frame(o, t0) for k, (o, t0) in odoms.items()}
    first = next(iter(paths.values()), None)
    start = np.zeros((1, 2)) if first is None else first[["x", "y"]].to_numpy()[:1]
    return Plots("track", start, [], paths, {}, {}, {})
