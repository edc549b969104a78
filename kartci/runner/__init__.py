"""Running many scenarios: validate, simulate, score, judge; serial, pooled, sharded or on Ray."""

from kartci.runner.executors import Event, EventKind, ExecutorKind
from kartci.runner.jobs import Job, Outcome, expand, parse_shard, shard
from kartci.runner.run import (
    ERROR_NAME,
    LOG_NAME,
    default_baselines,
    evaluate,
    rescore,
    run_one,
    scenario_folders,
    score,
)
from kartci.runner.suite import run_jobs

__all__ = ["ERROR_NAME", "LOG_NAME", "Event", "EventKind", "ExecutorKind", "Job", "Outcome",
           "default_baselines", "evaluate", "expand", "parse_shard", "rescore", "run_jobs",
           "run_one", "scenario_folders", "score", "shard"]
