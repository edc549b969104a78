"""Verdicts: baselines (load, compare, update) and pass criteria."""

from kartci.verdict.baseline import (
    SEVERITY,
    SPREAD_MULTIPLE,
    Change,
    Conditioning,
    CriterionResult,
    MetricVerdict,
    Policy,
    Status,
    check_criteria,
    compare,
    ill_conditioned,
    load,
    loosened,
    made_where,
    police,
    read_json,
    read_metrics,
    spread,
    update,
    worst,
    write_json_atomic,
)

__all__ = ["SEVERITY", "SPREAD_MULTIPLE", "Change", "Conditioning", "CriterionResult",
           "MetricVerdict", "Policy", "Status", "check_criteria", "compare", "ill_conditioned",
           "load", "loosened", "made_where", "police",
           "read_json", "read_metrics", "spread", "update", "worst", "write_json_atomic"]
