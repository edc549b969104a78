"""Verdicts: baselines (load, compare, update) and pass criteria."""

from kartci.verdict.baseline import (
    SEVERITY,
    Change,
    CriterionResult,
    MetricVerdict,
    Status,
    check_criteria,
    compare,
    load,
    read_json,
    read_metrics,
    update,
    worst,
    write_json_atomic,
)

__all__ = ["SEVERITY", "Change", "CriterionResult", "MetricVerdict", "Status", "check_criteria",
           "compare", "load", "read_json", "read_metrics", "update", "worst", "write_json_atomic"]
