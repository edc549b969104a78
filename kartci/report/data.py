"""deprecated: import from kartci.figures (PlotContext, wheel_series). Kept so a robot kind
written against the old path still runs."""

from kartci.figures import PlotContext, wheel_series

__all__ = ["PlotContext", "wheel_series"]
