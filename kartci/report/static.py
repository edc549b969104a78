"""The static rendering of report figures (matplotlib, SVG): the same `Figure`s as the
interactive report, for `report-static.html`, e-mail and anywhere JavaScript does not run."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.collections import LineCollection
from matplotlib.colors import Normalize
from matplotlib.ticker import LogFormatter

from kartci.plotstyle import svg  # also sets Agg, the SVG settings and the mathtext guard
from kartci.plotting import Axis, Figure, Plots, Role, Series, thin
from kartci.report.figures import scenario_figures

STYLE: dict[Role, dict[str, Any]] = {Role.REFERENCE: {"color": "grey", "ls": "--", "lw": 1.0},
         Role.COMMAND: {"ls": ":", "lw": 0.8}, Role.OUTLINE: {"color": "black", "lw": 0.8},
         Role.LINE: {"lw": 1.0}, Role.EVENTS: {"lw": 0}}


def _colour_range(f: Figure) -> tuple[float, float]:
    """The speed colour scale fitted to the data (2nd to 98th percentile), not from 0."""
    values = np.concatenate([s.c for s in f.series if s.c is not None] or [np.zeros(1)])
    lo, hi = (float(v) for v in np.nanpercentile(values, [2, 98]))
    return lo, hi if hi > lo else lo + 1e-6


def _coloured(ax: Axes, s: Series, lo: float, hi: float) -> LineCollection:
    pts = np.column_stack([s.x, s.y]).reshape(-1, 1, 2)
    segments = list(np.concatenate([pts[:-1], pts[1:]], axis=1))
    lc = LineCollection(segments, cmap="viridis", norm=Normalize(lo, hi), lw=2)
    assert s.c is not None
    lc.set_array(s.c[1:])
    ax.add_collection(lc)
    return lc


def _marks(ax: Axes, f: Figure) -> None:
    """Guides and events: crosses on the plane, dotted verticals on time and distance."""
    for y in f.hlines:
        ax.axhline(y, color="red", ls="--", lw=0.8)
    for e in f.events:
        if f.axis is Axis.PLANE:
            ax.scatter([e.x_m], [e.y_m], marker="x", color="red", s=50, zorder=5)
        else:
            ax.axvline(e.lap_m if f.axis is Axis.DISTANCE else e.t_s, color="red", ls=":", lw=0.8)


STATIC_POINTS = 400  # per series: a 5.5-inch figure shows no more, and SVG grows with each
# Axes placed by hand (fractions of the figure): tight_layout measured every tick label and
# was half of a figure's time; these margins hold six-character tick labels and a title.
MARGINS = {"left": 0.13, "right": 0.97, "bottom": 0.15, "top": 0.9}


def _fewer(s: Series) -> Series:
    if s.role in (Role.OUTLINE, Role.SHAPE) or len(s.x) <= STATIC_POINTS:
        return s
    i = thin(len(s.x), STATIC_POINTS)
    return replace(s, x=s.x[i], y=s.y[i], t=None if s.t is None else s.t[i],
                   c=None if s.c is None else s.c[i])


def figure_svg(f: Figure) -> str:
    """One figure as inline SVG, each series thinned to STATIC_POINTS."""
    f = replace(f, series=[_fewer(s) for s in f.series])
    fig, ax = plt.subplots(figsize=(5.5, 4.0 if f.axis is Axis.PLANE else 3.0))
    lo, hi = _colour_range(f)
    mappable = None
    for s in f.series:
        if s.role is Role.SHAPE:
            ax.fill(s.x, s.y, color="saddlebrown")
        elif s.c is not None:
            mappable = _coloured(ax, s, lo, hi)
        else:
            ax.plot(s.x, s.y, label=s.label if s.role is not Role.OUTLINE else None,
                    **STYLE.get(s.role, {}))
    _marks(ax, f)
    if mappable is not None:
        fig.colorbar(mappable, ax=ax, label=f.colour_label, shrink=0.8)
        ax.autoscale()
    if f.axis is Axis.PLANE:
        ax.set_aspect("equal", adjustable="datalim")
    if f.log_y:
        ax.set_yscale("log")
        # the default labels are mathtext ("$10^{1}$"), which plotstyle turns off for user
        # text: plain numbers, minor ticks labelled where few decades leave room
        ax.yaxis.set_major_formatter(LogFormatter())
        ax.yaxis.set_minor_formatter(LogFormatter(labelOnlyBase=False))
    ax.set_xlabel(f.xlabel)
    ax.set_ylabel(f.ylabel)
    ax.set_title(f.title, fontsize=8)
    if len(f.series) <= 12 and any(s.role not in (Role.OUTLINE, Role.SHAPE) and s.c is None
                                   for s in f.series):
        ax.legend(loc="best", fontsize=6)
    fig.subplots_adjust(**MARGINS)
    return svg(fig, tight=False)


def scenario_svgs(plots: Plots) -> tuple[str, ...]:
    """A scenario's figures as inline SVG, in the order the report shows them."""
    return tuple(figure_svg(f) for f in scenario_figures(plots))
