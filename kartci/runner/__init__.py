"""Running many scenarios: validate, simulate, score, judge."""

from kartci.runner.run import (
    ERROR_NAME,
    LOG_NAME,
    default_baselines,
    evaluate,
    rescore,
    run_one,
    run_specs,
    run_suite,
    score,
)

__all__ = ["ERROR_NAME", "LOG_NAME", "default_baselines", "evaluate", "rescore", "run_one",
           "run_specs", "run_suite", "score"]
