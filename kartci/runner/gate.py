"""Strict baselines: in CI, a scenario without a baseline, a metric its baseline lacks, a
baseline accepted from another scenario (stale) or a tolerance loosened beyond the policy is a
failure, not a quiet NEW or a warning that lets anything through."""

from __future__ import annotations

import os
import shlex
from dataclasses import replace
from pathlib import Path

from kartci.verdict import Status
from kartci.verdict.result import ScenarioResult


def strict_default() -> bool:
    """Strict when running in CI (`CI` set, as CI services do) unless told otherwise."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no")


def require_baselines(result: ScenarioResult, out: Path, baselines: Path) -> ScenarioResult:
    """The result with a problem for every metric judged NEW, saying how to accept it, and its
    strict warnings (a stale baseline, a loosened tolerance) made problems."""
    if result.error is not None:
        return result
    if result.strict_warnings:
        result = replace(result, problems=(*result.problems, *result.strict_warnings),
                         warnings=tuple(w for w in result.warnings
                                        if w not in result.strict_warnings), strict_warnings=())
    new = [v.name for v in result.verdicts if v.status is Status.NEW]
    path = baselines / f"{result.name}.json"
    has_file = path.exists() or path.is_symlink()
    if not new and (has_file or not result.verdicts):
        return result
    accept = (f"accept this run's values with `kartci baseline update {shlex.quote(str(out))} "
              f"{shlex.quote(result.name)}`")
    if not has_file:
        problem = f"no baseline {path} (strict mode); {accept}"
    else:
        problem = f"not in the baseline (strict mode): {', '.join(new)}; {accept}"
    return replace(result, problems=(*result.problems, problem))
