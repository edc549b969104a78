"""Figures as inline SVG (matplotlib, Agg): no JavaScript, no network, opens anywhere. One look
for the reports and a robot kind's own pages; importing this selects Agg and sets it."""

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


def finish(fig: Figure, ax: Axes, xlabel: str, ylabel: str, title: str) -> str:
    """Labels, title and legend, then the figure as inline SVG."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return svg(fig)


def svg(fig: Figure, tight: bool = True) -> str:
    """The figure as SVG text; laid out once (tight_layout, unless the caller placed the axes),
    not cropped with bbox_inches="tight", which draws every figure twice."""
    if tight:
        fig.tight_layout()
    buf = io.StringIO()
    fig.savefig(buf, format="svg", metadata={"Date": None})
    plt.close(fig)
    text = buf.getvalue()
    return text[text.index("<svg"):]
