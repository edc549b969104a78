"""kartci: record-and-replay CI harness for racing-kart and mobile-robot controllers.

The Python API, for a team's own scripts and tests:

- `run(scenario, overrides=..., agents=...)`: simulate, record, score and judge one scenario;
  returns a `RunResult` (metrics with units, verdicts against the baseline, criteria, log).
- `compare(base, head)`: one run judged against another (when no baseline is comparable).
- `accept_baselines(result_or_out)`: store runs as baselines, as `kartci baseline update`.
- `run_suite(names, shard=(i, n))`: many runs into one folder with reports, as `kartci run`;
  `merge(parts, out=...)` joins shards' folders, as `kartci merge`.
- `search(scenario, over)`: find a run that fails, shrunk toward the scenario's own values.
- `load_scenario(name_or_path, overrides)`: a validated `Scenario`.
- `Session(scenario, log_path, agents)`: a run you step yourself (`reset()`, `step()`).
- `Agent`: the protocol a controller satisfies (messages in, messages out).
- `kartci.core`: `Controller`, `MetricSet`, `register` and the other registries' types.
- `KartciError` and its subclasses: every problem kartci reports.

`import kartci` is cheap: the simulator, solvers and tables load when first used. It pins the
environment numpy, OpenBLAS and libm choose their machine code from (`kartci.portable`), so
import kartci before numpy, or runs go to a pinned child process.
"""

from __future__ import annotations

from kartci import portable
from kartci.errors import BaselineError, KartciError, LogError, RunError, SpecError

portable.prepare()  # before numpy loads: the same bits on every CPU (kartci.portable)

TYPE_CHECKING = False  # not `from typing import ...`: importing typing costs more than kartci
if TYPE_CHECKING:
    from typing import Any

    from kartci.api import (
        RunResult,
        accept_baselines,
        compare,
        load_scenario,
        merge,
        run,
        run_suite,
        search,
    )
    from kartci.core import Agent, Direction, Metric
    from kartci.scenario.models import Scenario
    from kartci.sim.session import RunInfo, Session, StepResult
    from kartci.verdict import CriterionResult, MetricVerdict, Status

# public name -> the module it lives in, imported on first access
_LAZY = {
    "Agent": "kartci.core",
    "CriterionResult": "kartci.verdict",
    "Direction": "kartci.core",
    "Metric": "kartci.core",
    "MetricVerdict": "kartci.verdict",
    "RunInfo": "kartci.sim.session",
    "RunResult": "kartci.api",
    "Scenario": "kartci.scenario.models",
    "Session": "kartci.sim.session",
    "Status": "kartci.verdict",
    "StepResult": "kartci.sim.session",
    "accept_baselines": "kartci.api",
    "compare": "kartci.api",
    "load_scenario": "kartci.api",
    "merge": "kartci.api",
    "run": "kartci.api",
    "run_suite": "kartci.api",
    "search": "kartci.api",
}

__all__ = [
    "Agent",
    "BaselineError",
    "CriterionResult",
    "Direction",
    "KartciError",
    "LogError",
    "Metric",
    "MetricVerdict",
    "RunError",
    "RunInfo",
    "RunResult",
    "Scenario",
    "Session",
    "SpecError",
    "Status",
    "StepResult",
    "accept_baselines",
    "compare",
    "load_scenario",
    "merge",
    "run",
    "run_suite",
    "search",
]
__version__ = "0.1.0"


def __getattr__(name: str) -> Any:
    """Import a public name's module on first access (keeps `import kartci` cheap)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'kartci' has no attribute '{name}'")
    value = getattr(__import__(module, fromlist=[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """Public names, including those not imported yet."""
    return sorted({*globals(), *__all__})
