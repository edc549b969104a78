"""What a run's figures draw and how: `Plots` (read back from a run log by a robot kind's
`plots`), the `Figure` value types the reports render, and the kind-neutral figure builders a
kind's `figures` picks from. Below the robot kinds, real-data import, the judge and the reports,
which all make or read these."""

from kartci.plotting.data import PlotContext, Plots, overlay, wheel_series
from kartci.plotting.figure import Axis, Event, Figure, FigureContext, Role, Series, thin

__all__ = ["Axis", "Event", "Figure", "FigureContext", "PlotContext", "Plots", "Role", "Series",
           "overlay", "thin", "wheel_series"]
