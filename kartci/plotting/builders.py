"""The figures any robot kind can draw from its `Plots`: the course seen from above, laps
overlaid, speed, commands, track-limit margins, localization error and wheel speeds over sim
time. A kind's `figures` function picks and extends them (`standard_figures` for a kind with
none of its own); the report lays out what the kind returns."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pandas as pd

from kartci.plotting.data import Plots
from kartci.plotting.figure import Axis, Event, Figure, FigureContext, Role, Series, thin


def col(frame: pd.DataFrame, name: str) -> np.ndarray:
    """A column as floats."""
    out: np.ndarray = frame[name].to_numpy(dtype=float)
    return out


def events(p: Plots) -> list[Event]:
    """Collisions of every agent, placed in time, on the plane and along the lap."""
    out: list[Event] = []
    for agent, hits in sorted(p.collisions.items()):
        for t, x, y, other in zip(col(hits, "t"), col(hits, "x"), col(hits, "y"),
                                  hits["other"].astype(str), strict=True):
            out.append(Event(f"{agent} collision with {other}", float(t), float(x), float(y),
                             lap_position(p, agent, float(t))))
    return out


def event_at(p: Plots, agent: str, t: float, label: str) -> Event:
    """An event of `agent` at sim time `t`, placed where its path says it was."""
    x, y = where(p, agent, t)
    return Event(f"{agent} {label}", t, x, y, lap_position(p, agent, t))


def where(p: Plots, agent: str, t: float) -> tuple[float, float]:
    """Where `agent`'s path was at sim time `t` (NaN without a path)."""
    tr = p.tracks.get(agent)
    if tr is None or tr.empty:
        return float("nan"), float("nan")
    tt = col(tr, "t")
    return float(np.interp(t, tt, col(tr, "x"))), float(np.interp(t, tt, col(tr, "y")))


def lap_position(p: Plots, agent: str, t: float) -> float:
    """Distance along the lap of `agent` at sim time `t` (NaN off a track)."""
    tr = p.tracks.get(agent)
    if tr is None or "s_total" not in tr or not p.track_length_m:
        return float("nan")
    s = float(np.interp(t, col(tr, "t"), col(tr, "s_total")))
    return s % p.track_length_m


def standard_figures(ctx: FigureContext) -> list[Figure]:
    """The figures of any robot on a course, in reading order: a kind without figures of its
    own gets these, and a kind's own list may start from them."""
    p, ev = ctx.plots, ctx.events
    return [plane(p, ev), *lap_overlays(p, ev), speed_time(p, ev), controls(p, ev),
            margins(p, ev), localization_error(p, ev), wheel_speeds(p, ev)]


def _path(label: str, tr: pd.DataFrame, role: Role = Role.LINE,
          colour: bool = False) -> Series:
    i = thin(len(tr))
    return Series(label, col(tr, "x")[i], col(tr, "y")[i], role, col(tr, "t")[i],
                  col(tr, "speed")[i] if colour and "speed" in tr else None)


def _closed(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.append(a[:, 0], a[0, 0]), np.append(a[:, 1], a[0, 1])


def plane(p: Plots, ev: list[Event], plans: Sequence[Series] = (),
          what: str = "path") -> Figure:
    """Seen from above: the course (track edges and centreline, or the line), obstacles, a
    kind's `plans` (what its controller meant to drive), every agent's `what` (its path, or
    the point of it that is scored) coloured by speed, the baseline's path and the events."""
    s: list[Series] = []
    if p.kind == "track":
        s += [Series(f"edge {i + 1}", *_closed(e), Role.OUTLINE) for i, e in enumerate(p.edges)]
        s.append(Series("centreline", *_closed(p.course), Role.REFERENCE))
        s += [Series(f"obstacle {i + 1}", *_closed(b), Role.SHAPE)
              for i, b in enumerate(p.obstacles)]
    else:
        s.append(Series("line", p.course[:, 0], p.course[:, 1], Role.OUTLINE))
    for agent, ref in sorted(p.reference.items()):
        s.append(_path(f"baseline {agent}", ref, Role.REFERENCE))
    s += plans
    s += [_path(f"{agent} {what}", tr, colour=True) for agent, tr in p.tracks.items()]
    s += [_path(f"{agent} localization estimate", est) for agent, est in p.estimates.items()]
    s += _detections(p)
    return Figure("plane", "seen from above (colour: speed; hover a time plot to follow it)",
                  "x [m]", "y [m]", Axis.PLANE, s, ev, colour_label="speed [m/s]")


def _detections(p: Plots) -> list[Series]:
    """Detected boxes, static filled and dynamic outlined (two colours in the seed's Fig. 6.4)."""
    return [Series(f"{agent} detected {'dynamic' if dynamic else 'static'} {i + 1}", *_closed(box),
                   Role.OUTLINE if dynamic else Role.SHAPE)
            for agent, boxes in p.detections.items() for i, (box, dynamic) in enumerate(boxes)]


def _laps(label: str, tr: pd.DataFrame, column: str, length_m: float,
          role: Role) -> list[Series]:
    """One series per lap (distance from the lap line, value of `column`)."""
    total = col(tr, "s_total")
    lap = np.floor(total / length_m).astype(int)
    out = []
    for k in np.unique(lap):
        rows = np.flatnonzero(lap == k)
        if len(rows) < 2:
            continue
        i = rows[thin(len(rows))]
        name = f"{label} lap {k + 1}" if k >= 0 else f"{label} before the line"
        out.append(Series(name, total[i] - k * length_m, col(tr, column)[i], role,
                          col(tr, "t")[i]))
    return out


def lap_overlays(p: Plots, ev: list[Event]) -> list[Figure]:
    """Speed and cross-track error against distance along the lap, every lap overlaid (and the
    baseline's laps, dashed)."""
    if not p.track_length_m or not all("s_total" in tr for tr in p.tracks.values()):
        return []
    out = []
    for column, title, ylabel in (("speed", "speed along the lap, every lap overlaid",
                                   "speed [m/s]"),
                                  ("offset", "cross-track error along the lap (left +)",
                                   "cross-track error [m]")):
        s: list[Series] = []
        for agent, ref in sorted(p.reference.items()):
            if "s_total" in ref and column in ref:
                s += _laps(f"baseline {agent}", ref, column, p.track_length_m, Role.REFERENCE)
        for agent, tr in p.tracks.items():
            s += _laps(agent, tr, column, p.track_length_m, Role.LINE)
        out.append(Figure(f"lap_{column}", title, "distance from the lap line [m]", ylabel,
                          Axis.DISTANCE, s, ev, hlines=(0.0,) if column == "offset" else ()))
    return out


def time_series(label: str, frame: pd.DataFrame, column: str, role: Role = Role.LINE) -> Series:
    """`column` of `frame` over sim time, thinned."""
    i = thin(len(frame))
    t = col(frame, "t")[i]
    return Series(label, t, col(frame, column)[i], role, t)


def speed_time(p: Plots, ev: list[Event]) -> Figure:
    """Speed over sim time (the baseline's dashed)."""
    s = [time_series(f"baseline {a}", ref, "speed", Role.REFERENCE)
         for a, ref in sorted(p.reference.items()) if "speed" in ref]
    s += [time_series(a, tr, "speed") for a, tr in p.tracks.items()]
    return Figure("speed", "speed", "sim time [s]", "speed [m/s]", Axis.TIME, s, ev)


def controls(p: Plots, ev: list[Event]) -> Figure:
    """The driver's commands over sim time: steering-wheel angle, acceleration and brake."""
    s = [time_series(f"{a} {c}", frame, c) for a, frame in p.controls.items()
         for c in frame.columns if c != "t"]
    return Figure("controls", "commands", "sim time [s]", "command [rad or m/s²]", Axis.TIME,
                  s, ev)


def margins(p: Plots, ev: list[Event]) -> Figure:
    """Distance from the wheel nearest a track edge to that edge; below 0 is off track."""
    s = [time_series(a, m, "margin_m") for a, m in p.margins.items()]
    return Figure("margin", "track-limit margin (nearest wheel to an edge; < 0: off track)",
                  "sim time [s]", "margin [m]", Axis.TIME, s, ev, hlines=(0.0,))


def localization_error(p: Plots, ev: list[Event]) -> Figure:
    """Position error of each localization estimate against the truth (APE) over sim time."""
    s = [time_series(a, est, "error_m") for a, est in p.estimates.items()]
    return Figure("localization", "localization error (APE translation)", "sim time [s]",
                  "position error [m]", Axis.TIME, s, ev)


def wheel_speeds(p: Plots, ev: list[Event]) -> Figure:
    """Measured wheel speeds, and the commanded ones where the controller commands wheel speeds
    (a differential drive; a car-like robot is commanded by pedals and steering: see the
    commands plot)."""
    s = [time_series(f"{a} {side}", w, side) for a, w in p.wheels.items()
         for side in ("left", "right")]
    s += [time_series(f"{a} {side} commanded", c, side, Role.COMMAND)
          for a, c in p.commands.items() for side in ("left", "right")]
    title = ("wheel speeds: measured (solid), commanded (dotted)" if p.commands
             else "driven wheel speeds (measured)")
    return Figure("wheels", title, "sim time [s]", "wheel speed [rad/s]", Axis.TIME, s, ev)
