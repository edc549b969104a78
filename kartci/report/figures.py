"""The figures of one scenario in a report: what its robot kind draws (`RobotKind.figures`,
from the kind's own package), or the kind-neutral figures for a kind without its own; laid out
in the order the kind returns them, empty ones left out."""

from __future__ import annotations

import contextlib

from kartci.core import ROBOTS, FiguresFn
from kartci.errors import KartciError
from kartci.plotting import Figure, FigureContext, Plots
from kartci.plotting.builders import events, standard_figures


def scenario_figures(p: Plots) -> list[Figure]:
    """Every figure of one scenario, in reading order."""
    ctx = FigureContext(p, events(p))
    draw: FiguresFn = standard_figures
    if p.robot:
        # a report of a run whose kind is not installed here: the kind-neutral figures
        with contextlib.suppress(KartciError):
            draw = ROBOTS.get(p.robot).figures or standard_figures
    return [f for f in draw(ctx) if f.series]
