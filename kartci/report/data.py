"""deprecated: import from kartci.plotting (PlotContext, wheel_series). Kept so a robot kind
written against the old path still runs."""

from kartci.plotting import PlotContext, wheel_series

__all__ = ["PlotContext", "wheel_series"]
