"""What a report draws, as data: `Figure`s of named series and marked events, which two
renderers draw: the interactive report (uPlot, see `kartci.report.interactive`) and static SVG
(`kartci.report.static`, for e-mail and Markdown). A robot kind builds its figures from its
`Plots` (`RobotKind.figures`); both renderers draw any figure without change."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum

import numpy as np

from kartci.plotting.data import Plots

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




@dataclass(frozen=True)
class FigureContext:
    """What a robot kind's `figures` function reads: the scenario's `Plots` and the events
    every kind marks (collisions), placed in time, on the plane and along the lap."""

    plots: Plots
    events: list[Event]
