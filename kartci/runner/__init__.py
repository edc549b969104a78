"""Running many scenarios: validate, simulate, score, judge."""

from kartci.runner.run import (
    LOG_NAME,
    default_baselines,
    evaluate,
    rescore,
    run_one,
    run_suite,
    score,
)

__all__ = ["LOG_NAME", "default_baselines", "evaluate", "rescore", "run_one", "run_suite",
           "score"]
