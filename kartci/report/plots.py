"""Report figures as inline SVG (matplotlib, Agg): no JavaScript, no network, opens anywhere."""

from __future__ import annotations

import io

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.axes import Axes
from matplotlib.figure import Figure

# Labels carry user text (agent names): `$` must stay a dollar sign, never start mathtext, which
# fails on text like `a$\\foo{$b` and took the whole report down.
# Text stays text (svg.fonttype none), not glyph outlines: a fifth faster to write, a third
# smaller, and searchable in the page.
plt.rcParams.update({"svg.hashsalt": "kartci", "figure.dpi": 96, "font.size": 9,
                     "text.parse_math": False, "svg.fonttype": "none"})


def _finish(fig: Figure, ax: Axes, xlabel: str, ylabel: str, title: str) -> str:
    """Labels, title and legend, then the figure as inline SVG."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return _svg(fig)


def _svg(fig: Figure) -> str:
    """The figure as SVG text; laid out once (tight_layout), not cropped with
    bbox_inches="tight", which draws every figure twice (a third of the static report's time)."""
    fig.tight_layout()
    buf = io.StringIO()
    fig.savefig(buf, format="svg", metadata={"Date": None})
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]


def sensor_sweep(offsets_m: list[float], curves: dict[str, list[float]], title: str) -> str:
    """Line-sensor luminance curves against the sensor's lateral offset (mm), its ±8 mm range
    marked."""
    fig, ax = plt.subplots(figsize=(5.5, 3.5))
    for label, ys in curves.items():
        ax.plot([o * 1000 for o in offsets_m], ys, lw=1.2, label=label)
    ax.axvline(-8, color="grey", ls="--", lw=0.8)
    ax.axvline(8, color="grey", ls="--", lw=0.8)
    return _finish(fig, ax, "offset of the sensor from the line axis [mm]", "luminance", title)
