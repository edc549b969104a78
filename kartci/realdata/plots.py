"""What a report draws for an imported log: the path (on its track, if any) and the speed."""

from __future__ import annotations

import numpy as np
import pandas as pd

from kartci.metrics.kart import kart_track
from kartci.report.data import PlotContext
from kartci.results import Plots
from kartci.track import TRACK_TOPIC, track_from_text


def path_frame(odom: pd.DataFrame) -> pd.DataFrame:
    """t (from the first pose), x, y, speed and a zero offset: a path as the plots draw it."""
    return pd.DataFrame({"t": odom["t"] - odom["t"].iloc[0], "x": odom["x"], "y": odom["y"],
                         "speed": np.hypot(odom["vx"], odom["vy"]), "offset": 0.0})


def recorded_plots(ctx: PlotContext) -> Plots:
    """Every agent's path and speed; drawn on the track when the log holds one, else from the
    first pose (the start marker)."""
    tracks = {a: path_frame(o) for a in ctx.scenario.agents
              if (o := ctx.tables.get(f"/{a}/odom")) is not None and not o.empty}
    table = ctx.tables.get(TRACK_TOPIC)
    if table is not None and not table.empty:
        track = track_from_text(str(table["data"].iloc[0]), "recorded track")
        tracks = {a: kart_track(track, ctx.tables[f"/{a}/odom"].assign(t=df["t"]))
                  for a, df in tracks.items()}
        return Plots("track", track.xy, list(track.bounds()), tracks, {}, {}, {})
    first = next(iter(tracks.values()), None)
    start = np.zeros((1, 2)) if first is None else first[["x", "y"]].to_numpy()[:1]
    return Plots("track", start, [], tracks, {}, {}, {})
