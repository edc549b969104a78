"""Verdicts: baselines (load, compare, update), pass criteria, and the one result of a
scenario."""

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
    spread,
    update,
    worst,
    write_json_atomic,
)
from kartci.verdict.result import ScenarioResult, exit_code, one_line

__all__ = ["SEVERITY", "SPREAD_MULTIPLE", "Change", "Conditioning", "CriterionResult",
           "MetricVerdict", "Policy", "ScenarioResult", "Status", "check_criteria", "compare",
           "exit_code", "ill_conditioned", "load", "loosened", "made_where", "one_line", "police",
           "read_json", "spread", "update", "worst", "write_json_atomic"]
