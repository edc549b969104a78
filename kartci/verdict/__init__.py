"""Verdicts: baselines (read, compare, update), pass criteria, judging a run folder
(`judging`), and the one result of a scenario (`ScenarioResult`, alias `RunResult`)."""

from kartci.verdict.baseline import (
    SEVERITY,
    SPREAD_MULTIPLE,
    Baseline,
    Change,
    Conditioning,
    CriterionResult,
    MetricVerdict,
    Policy,
    Status,
    apply_tolerance_policy,
    check_criteria,
    compare,
    ill_conditioned,
    load,
    loose_tolerance_messages,
    read_baseline,
    read_json,
    spread,
    update,
    worst,
    write_json_atomic,
)
from kartci.verdict.result import RunResult, ScenarioResult, exit_code

__all__ = ["SEVERITY", "SPREAD_MULTIPLE", "Baseline", "Change", "Conditioning", "CriterionResult",
           "MetricVerdict", "Policy", "RunResult", "ScenarioResult", "Status",
           "apply_tolerance_policy", "check_criteria", "compare", "exit_code", "ill_conditioned",
           "load", "loose_tolerance_messages", "read_baseline", "read_json", "spread",
           "update", "worst", "write_json_atomic"]
