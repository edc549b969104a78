"""Report figures as inline SVG (matplotlib, Agg): no JavaScript, no network, opens anywhere."""

from __future__ import annotations

import io

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from kartci.results import Plots

# Labels carry user text (agent names): `$` must stay a dollar sign, never start mathtext, which
# fails on text like `a$\\foo{$b` and took the whole report down.
plt.rcParams.update({"svg.hashsalt": "kartci", "figure.dpi": 96, "font.size": 9,
                     "text.parse_math": False})


def _finish(fig: Figure, ax: Axes, xlabel: str, ylabel: str, title: str) -> str:
    """Labels, title and legend, then the figure as inline SVG."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return _svg(fig)


def _svg(fig: Figure) -> str:
    buf = io.StringIO()
    fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]


def top_view(p: Plots) -> str:
    """Paths seen from above: on a track (edges, obstacles, MPCC horizons, collisions; a lone
    path coloured by speed), or along a line."""
    fig, ax = plt.subplots(figsize=(5.5, 4.0))
    if p.kind == "track":
        _track_outline(ax, p)
        _track_paths(fig, ax, p)
        _track_overlays(ax, p)
    else:
        ax.plot(p.course[:, 0], p.course[:, 1], color="black", lw=3, label="line", alpha=0.35)
        for agent, tr in p.tracks.items():
            ax.plot(tr["x"], tr["y"], lw=1.2, label=f"{agent} sensor point")
    ax.set_aspect("equal", adjustable="datalim")
    return _finish(fig, ax, "x [m]", "y [m]", "path seen from above")


def _track_outline(ax: Axes, p: Plots) -> None:
    """The track's edges, its centreline and the start / finish line."""
    for edge in p.edges:
        ax.plot(*_closed(edge), color="black", lw=1)
    ax.plot(*_closed(p.course), color="grey", lw=0.6, ls="--", label="centreline")
    ax.plot(*p.course[0], marker="|", color="black", ms=14, label="start / finish")


def _track_paths(fig: Figure, ax: Axes, p: Plots) -> None:
    """Several paths (karts, or base and head) one colour each; a lone path coloured by speed."""
    if len(p.tracks) > 1:
        for agent, tr in p.tracks.items():
            ax.plot(tr["x"], tr["y"], lw=1.2, label=f"{agent} path")
    for agent, tr in p.tracks.items() if len(p.tracks) == 1 else ():
        sc = ax.scatter(tr["x"], tr["y"], c=tr["speed"], s=2, cmap="viridis", vmin=0,
                        vmax=max(float(tr["speed"].max()), 1.0), label=f"{agent} path")
        fig.colorbar(sc, ax=ax, label="speed [m/s]", shrink=0.8)


def _track_overlays(ax: Axes, p: Plots) -> None:
    """Obstacles, a few MPCC horizons and the collisions, over the paths."""
    for i, box in enumerate(p.obstacles):
        ax.fill(*_closed(box), color="saddlebrown", zorder=4,
                label="obstacles" if i == 0 else None)
    for agent, plans in p.horizons.items():
        for i, plan in enumerate(plans):
            ax.plot(plan[:, 0], plan[:, 1], color="magenta", lw=2, alpha=0.9, zorder=6,
                    label=f"{agent} MPCC horizons" if i == 0 else None)
    for agent, col in p.collisions.items():
        ax.scatter(col["x"], col["y"], marker="x", color="red", s=60, zorder=5,
                   label=f"{agent} collisions ({len(col)})")


def _closed(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.append(a[:, 0], a[0, 0]), np.append(a[:, 1], a[0, 1])


def speed(p: Plots) -> str:
    """Speed over sim time of every agent, collisions marked."""
    fig, ax = plt.subplots(figsize=(5.5, 3.0))
    for agent, tr in p.tracks.items():
        ax.plot(tr["t"], tr["speed"], lw=1, label=agent)
    for col in p.collisions.values():
        for t in col["t"]:
            ax.axvline(t, color="red", lw=0.8, ls=":")
    return _finish(fig, ax, "sim time [s]", "speed [m/s]", "speed (dotted red: collisions)")


def solve_times(p: Plots) -> str:
    """MPCC solve time (wall clock, ms, log scale) over sim time, failed solves marked."""
    fig, ax = plt.subplots(figsize=(5.5, 3.0))
    for agent, st in p.solves.items():
        ax.plot(st["t"], st["solve_ms"], lw=0.8, label=f"{agent}")
        failed = st[~st["success"].astype(bool)]
        if len(failed):
            ax.scatter(failed["t"], failed["solve_ms"], marker="x", color="red", s=30,
                       label=f"{agent} failed ({len(failed)})")
    ax.set_yscale("log")
    return _finish(fig, ax, "sim time [s]", "solve time [ms]", "MPCC solve time (wall clock)")


def tracking_error(p: Plots, band_m: float = 0.008) -> str:
    """Cross-track error (mm) over sim time, with the line sensor's range `band_m` (m) and the
    unscored start-up transient shown."""
    fig, ax = plt.subplots(figsize=(5.5, 3.0))
    for agent, tr in p.tracks.items():
        ax.plot(tr["t"], tr["offset"] * 1000, lw=1, label=agent)
    for s in (-1, 1):
        ax.axhline(s * band_m * 1000, color="red", ls="--", lw=0.8)
    if p.transient_s > 0:
        ax.axvspan(0, p.transient_s, color="grey", alpha=0.15, label="transient (not scored)")
    return _finish(fig, ax, "sim time [s]", "cross-track error [mm]",
                   f"tracking error (dashed: ±{band_m * 1000:g} mm sensor range)")


def wheel_speeds(p: Plots) -> str:
    """Measured and commanded wheel speeds (rad/s) over sim time."""
    fig, ax = plt.subplots(figsize=(5.5, 3.0))
    for agent, w in p.wheels.items():
        ax.plot(w["t"], w["left"], lw=1, label=f"{agent} left")
        ax.plot(w["t"], w["right"], lw=1, label=f"{agent} right")
    for agent, c in p.commands.items():
        ax.plot(c["t"], c["left"], lw=0.7, ls=":", label=f"{agent} left cmd")
        ax.plot(c["t"], c["right"], lw=0.7, ls=":", label=f"{agent} right cmd")
    ax.set_xlabel("sim time [s]")
    ax.set_ylabel("wheel speed [rad/s]")
    ax.set_title("wheel speeds: measured (solid) and commanded (dotted)")
    ax.legend(loc="best", fontsize=7, ncol=2)
    return _svg(fig)


def sensor_sweep(offsets_m: list[float], curves: dict[str, list[float]], title: str) -> str:
    """Line-sensor luminance curves against the sensor's lateral offset (mm), its ±8 mm range
    marked."""
    fig, ax = plt.subplots(figsize=(5.5, 3.5))
    for label, ys in curves.items():
        ax.plot([o * 1000 for o in offsets_m], ys, lw=1.2, label=label)
    ax.axvline(-8, color="grey", ls="--", lw=0.8)
    ax.axvline(8, color="grey", ls="--", lw=0.8)
    return _finish(fig, ax, "offset of the sensor from the line axis [mm]", "luminance", title)
