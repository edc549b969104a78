"""deprecated: import from kartci.verdict (ScenarioResult, exit_code, one_line) and
kartci.figures (Plots, overlay). Kept so code written against the old path still runs."""

from kartci.errors import one_line
from kartci.figures import Plots, overlay
from kartci.verdict.result import ScenarioResult, exit_code

__all__ = ["Plots", "ScenarioResult", "exit_code", "one_line", "overlay"]
