"""deprecated: import from kartci.verdict (ScenarioResult, exit_code, one_line) and
kartci.plotting (Plots, overlay). Kept so code written against the old path still runs."""

from kartci.plotting import Plots, overlay
from kartci.verdict.result import ScenarioResult, exit_code, one_line

__all__ = ["Plots", "ScenarioResult", "exit_code", "one_line", "overlay"]
