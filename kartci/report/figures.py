"""What a report draws, as data: a scenario's `Plots` (read from its log) become `Figure`s of
named series and marked events, which two renderers draw: the interactive report (uPlot, see
`kartci.report.interactive`) and static SVG (`kartci.report.static`, for e-mail and Markdown).
A new plot is one more builder here; both renderers draw it without change."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np
import pandas as pd

from kartci.figures import Plots

MAX_POINTS = 2000  # per series in a report: a 50 Hz, 60 s run is 3000 samples


class Axis(StrEnum):
    """What a figure's x axis is: sim time (its cursor is shared across a scenario's time
    figures and shown as a dot on the plane view), distance along a lap, or the plane (x, y)."""

    TIME = "time"
    DISTANCE = "distance"
    PLANE = "plane"
    COMMIT = "commit"  # metric history: x is the commit's index, `Figure.ticks` its name


class Role(StrEnum):
    """How a series is drawn: a line, a reference (the baseline's, dashed grey), a dotted
    command line, a closed outline, a filled shape, or event markers (crosses)."""

    LINE = "line"
    REFERENCE = "reference"
    COMMAND = "command"
    OUTLINE = "outline"
    SHAPE = "shape"
    EVENTS = "events"


@dataclass(frozen=True)
class Series:
    """One named line or set of points; `t` (sim time of each point) lets a plane view follow
    the time cursor, `c` colours a plane path point by point (speed)."""

    label: str
    x: np.ndarray
    y: np.ndarray
    role: Role = Role.LINE
    t: np.ndarray | None = None
    c: np.ndarray | None = None


@dataclass(frozen=True)
class Event:
    """Something that happened at a moment (a collision, a failed solve), marked on every figure:
    at its time, at its distance along the lap, or at its place."""

    label: str
    t_s: float
    x_m: float = float("nan")
    y_m: float = float("nan")
    lap_m: float = float("nan")


@dataclass(frozen=True)
class Figure:
    """One plot: title, axis labels, kind of x axis, series and events."""

    key: str
    title: str
    xlabel: str
    ylabel: str
    axis: Axis
    series: list[Series]
    events: list[Event] = field(default_factory=list)
    log_y: bool = False
    colour_label: str = ""  # what `Series.c` is (plane views), e.g. "speed [m/s]"
    hlines: tuple[float, ...] = ()  # horizontal guides (sensor range, track edge)
    ticks: tuple[str, ...] = ()  # names of the integer x values (commits)


def thin(n: int, limit: int = MAX_POINTS) -> np.ndarray:
    """Indices of at most `limit` of `n` evenly spread samples, first and last kept."""
    if n <= limit:
        return np.arange(n)
    out: np.ndarray = np.unique(np.linspace(0, n - 1, limit).round().astype(int))
    return out


def _col(frame: pd.DataFrame, name: str) -> np.ndarray:
    out: np.ndarray = frame[name].to_numpy(dtype=float)
    return out


def events(p: Plots) -> list[Event]:
    """Collisions and failed solves of every agent, placed in time, on the plane and along the
    lap (where the agent's path says where it was)."""
    out: list[Event] = []
    for agent, col in sorted(p.collisions.items()):
        for t, x, y, other in zip(_col(col, "t"), _col(col, "x"), _col(col, "y"),
                                  col["other"].astype(str), strict=True):
            out.append(Event(f"{agent} collision with {other}", float(t), float(x), float(y),
                             _lap_position(p, agent, float(t))))
    for agent, st in sorted(p.solves.items()):
        failed = st[~st["success"].astype(bool)]
        for t in _col(failed, "t"):
            x, y = _where(p, agent, float(t))
            out.append(Event(f"{agent} solver failure", float(t), x, y,
                             _lap_position(p, agent, float(t))))
    return out


def _where(p: Plots, agent: str, t: float) -> tuple[float, float]:
    tr = p.tracks.get(agent)
    if tr is None or tr.empty:
        return float("nan"), float("nan")
    tt = _col(tr, "t")
    return float(np.interp(t, tt, _col(tr, "x"))), float(np.interp(t, tt, _col(tr, "y")))


def _lap_position(p: Plots, agent: str, t: float) -> float:
    tr = p.tracks.get(agent)
    if tr is None or "s_total" not in tr or not p.track_length_m:
        return float("nan")
    s = float(np.interp(t, _col(tr, "t"), _col(tr, "s_total")))
    return s % p.track_length_m


def scenario_figures(p: Plots) -> list[Figure]:
    """Every figure of one scenario, in reading order."""
    ev = events(p)
    if p.kind == "track":
        figs = [plane(p, ev), *lap_overlays(p, ev), speed_time(p, ev), controls(p, ev),
                margins(p, ev), localization_error(p, ev), wheel_speeds(p, ev),
                solve_times(p, ev)]
    else:
        figs = [plane(p, ev), tracking_error(p, ev), wheel_speeds(p, ev)]
    return [f for f in figs if f is not None and f.series]


def _path(label: str, tr: pd.DataFrame, role: Role = Role.LINE,
          colour: bool = False) -> Series:
    i = thin(len(tr))
    return Series(label, _col(tr, "x")[i], _col(tr, "y")[i], role, _col(tr, "t")[i],
                  _col(tr, "speed")[i] if colour and "speed" in tr else None)


def _closed(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.append(a[:, 0], a[0, 0]), np.append(a[:, 1], a[0, 1])


def plane(p: Plots, ev: list[Event]) -> Figure:
    """Seen from above: the course (track edges and centreline, or the line), obstacles, MPCC
    horizons, every path coloured by speed, the baseline's path and the events."""
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
    for agent, plans in sorted(p.horizons.items()):
        s += [Series(f"{agent} MPCC horizon {i + 1}", plan[:, 0], plan[:, 1], Role.COMMAND)
              for i, plan in enumerate(plans)]
    what = "path" if p.kind == "track" else "sensor point"
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
    total = _col(tr, "s_total")
    lap = np.floor(total / length_m).astype(int)
    out = []
    for k in np.unique(lap):
        rows = np.flatnonzero(lap == k)
        if len(rows) < 2:
            continue
        i = rows[thin(len(rows))]
        name = f"{label} lap {k + 1}" if k >= 0 else f"{label} before the line"
        out.append(Series(name, total[i] - k * length_m, _col(tr, column)[i], role,
                          _col(tr, "t")[i]))
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


def _time(label: str, frame: pd.DataFrame, column: str, role: Role = Role.LINE) -> Series:
    i = thin(len(frame))
    t = _col(frame, "t")[i]
    return Series(label, t, _col(frame, column)[i], role, t)


def speed_time(p: Plots, ev: list[Event]) -> Figure:
    """Speed over sim time (the baseline's dashed)."""
    s = [_time(f"baseline {a}", ref, "speed", Role.REFERENCE)
         for a, ref in sorted(p.reference.items()) if "speed" in ref]
    s += [_time(a, tr, "speed") for a, tr in p.tracks.items()]
    return Figure("speed", "speed", "sim time [s]", "speed [m/s]", Axis.TIME, s, ev)


def controls(p: Plots, ev: list[Event]) -> Figure:
    """The driver's commands over sim time: steering-wheel angle, acceleration and brake."""
    s = [_time(f"{a} {c}", frame, c) for a, frame in p.controls.items()
         for c in frame.columns if c != "t"]
    return Figure("controls", "commands", "sim time [s]", "command [rad or m/s²]", Axis.TIME,
                  s, ev)


def margins(p: Plots, ev: list[Event]) -> Figure:
    """Distance from the wheel nearest a track edge to that edge; below 0 is off track."""
    s = [_time(a, m, "margin_m") for a, m in p.margins.items()]
    return Figure("margin", "track-limit margin (nearest wheel to an edge; < 0: off track)",
                  "sim time [s]", "margin [m]", Axis.TIME, s, ev, hlines=(0.0,))


def tracking_error(p: Plots, ev: list[Event], band_m: float = 0.008) -> Figure:
    """Cross-track error (m) over sim time, the sensor's range marked (and the baseline's)."""
    s = [_time(f"baseline {a}", ref, "offset", Role.REFERENCE)
         for a, ref in sorted(p.reference.items()) if "offset" in ref]
    s += [_time(a, tr, "offset") for a, tr in p.tracks.items()]
    note = f", first {p.transient_s:g} s not scored" if p.transient_s > 0 else ""
    return Figure("tracking", f"cross-track error (guides: ±{band_m * 1000:g} mm sensor range"
                  f"{note})", "sim time [s]", "cross-track error [m]", Axis.TIME, s, ev,
                  hlines=(-band_m, band_m))


def localization_error(p: Plots, ev: list[Event]) -> Figure:
    """Position error of each localization estimate against the truth (APE) over sim time."""
    s = [_time(a, est, "error_m") for a, est in p.estimates.items()]
    return Figure("localization", "localization error (APE translation)", "sim time [s]",
                  "position error [m]", Axis.TIME, s, ev)


def wheel_speeds(p: Plots, ev: list[Event]) -> Figure:
    """Measured wheel speeds, and the commanded ones where the controller commands wheel speeds
    (a line tracker; a kart is commanded by pedals and steering: see the commands plot)."""
    s = [_time(f"{a} {side}", w, side) for a, w in p.wheels.items() for side in ("left", "right")]
    s += [_time(f"{a} {side} commanded", c, side, Role.COMMAND)
          for a, c in p.commands.items() for side in ("left", "right")]
    title = ("wheel speeds: measured (solid), commanded (dotted)" if p.commands
             else "driven wheel speeds (measured)")
    return Figure("wheels", title, "sim time [s]", "wheel speed [rad/s]", Axis.TIME, s, ev)


def solve_times(p: Plots, ev: list[Event]) -> Figure:
    """MPCC solve time (wall clock, ms, log scale) over sim time."""
    s = [_time(a, st, "solve_ms") for a, st in p.solves.items()]
    return Figure("solves", "MPCC solve time (wall clock)", "sim time [s]", "solve time [ms]",
                  Axis.TIME, s, ev, log_y=True)
