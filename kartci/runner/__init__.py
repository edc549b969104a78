"""Running many scenarios: validate, simulate, score, judge; serial, pooled, sharded or on Ray.

The names below load their module on first use, so `kartci --help` or `kartci.runner.kinds`
does not import the simulator."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from kartci.runner.events import Event, EventKind
    from kartci.runner.jobs import (
        Job,
        Outcome,
        Refused,
        expand,
        parse_shard,
        runnable,
        shard,
        shard_labels,
    )
    from kartci.runner.kinds import ExecutorKind
    from kartci.runner.run import (
        evaluate,
        rescore,
        run_one,
        scenario_folders,
        score,
    )
    from kartci.runner.suite import refused_results, run_jobs

_WHERE = {"Event": "events", "EventKind": "events", "ExecutorKind": "kinds",
          "Job": "jobs", "Outcome": "jobs", "Refused": "jobs", "shard_labels": "jobs",
          "expand": "jobs", "parse_shard": "jobs", "runnable": "jobs",
          "shard": "jobs",
          "evaluate": "run", "rescore": "run", "run_one": "run", "scenario_folders": "run",
          "score": "run", "refused_results": "suite", "run_jobs": "suite"}


def __getattr__(name: str) -> Any:
    """A public name, imported from its module on first use."""
    where = _WHERE.get(name)
    if where is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"kartci.runner.{where}"), name)


__all__ = ["Event", "EventKind", "ExecutorKind", "Job", "Outcome", "Refused",
           "evaluate", "expand", "parse_shard", "refused_results",
           "rescore", "run_jobs", "run_one", "runnable", "scenario_folders", "score", "shard",
           "shard_labels"]
