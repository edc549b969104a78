"""Plots of the source document's study figures (`study.Panel`), as SVG text: kept apart from the
report's rendering, which embeds or links them as it likes."""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.figure import Figure

from kartci.robots.line_tracker.study import Panel

NAMES = {"agents.lt0.controller.kp": "Kp", "agents.lt0.controller.period_s": "ts",
         "agents.lt0.controller.v1_mps": "v1", "world.course.radius_m": "r"}
UNITS = {"agents.lt0.controller.period_s": " s", "agents.lt0.controller.v1_mps": " m/s",
         "world.course.radius_m": " m"}


def _svg(fig: Figure) -> str:
    buf = io.StringIO()
    fig.savefig(buf, format="svg", bbox_inches="tight", metadata={"Date": None})
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]


def _name(panel: Panel, value: float) -> str:
    return f"{NAMES.get(panel.varies, panel.varies)} {value:g}{UNITS.get(panel.varies, '')}"


def responses(panel: Panel, band_m: float = 0.008, t_max_s: float = 6.0) -> str:
    """Sensor offset over time, one curve per value of the varied parameter (Figs. 7.1.2-4),
    over the first `t_max_s` (the releases settle within it from Kp 50 up)."""
    fig, ax = plt.subplots(figsize=(6.0, 3.4))
    for c in sorted(panel.curves, key=lambda c: c.point.get(panel.varies, 0.0)):
        ax.plot(c.t_s, 1000 * c.offset_m, lw=1.1, label=_name(panel, c.point[panel.varies]))
    ax.axhline(0.0, color="black", lw=0.6)
    ax.set_xlim(0.0, t_max_s)
    ax.set_ylim(-1000 * band_m, 1000 * band_m)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("sensor offset from the line [mm]")
    ax.set_title(f"{panel.figure} (kartci): {panel.title}")
    ax.legend(loc="best", fontsize=8)
    return _svg(fig)


def circle_distance(panel: Panel, band_m: float = 0.008) -> str:
    """Sensor offset over the angle travelled round the circle, one curve per value (Sec. 7.2),
    with the sensor's +-8 mm range."""
    fig, ax = plt.subplots(figsize=(6.0, 3.4))
    for c in sorted(panel.curves, key=lambda c: c.point.get(panel.varies, 0.0)):
        ax.plot(c.angle_deg, 1000 * c.offset_m, lw=1.0, label=_name(panel, c.point[panel.varies]))
    for y in (-band_m, band_m):
        ax.axhline(1000 * y, color="red", lw=0.7, ls="--")
    ax.set_xlim(0.0, 360.0)
    ax.set_ylim(-2500 * band_m, 2500 * band_m)
    ax.set_xlabel("angle travelled [deg]")
    ax.set_ylabel("sensor offset from the line [mm]")
    ax.set_title(f"{panel.figure} (kartci): {panel.title}")
    ax.legend(loc="best", fontsize=8)
    return _svg(fig)
