"""Comparing two runs of the Python API, head against base: what to do when no baseline is
comparable (a run with other overrides or an agent object), as `kartci compare` does for two
output folders."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from kartci.core import RunFolder
from kartci.runner.compare import samples
from kartci.verdict import load
from kartci.verdict.result import ScenarioResult
from kartci.verdict.runs import ALPHA, compare_runs


def compare_results(base: ScenarioResult, head: ScenarioResult, baselines: Path,
                    alpha: float = ALPHA) -> ScenarioResult:
    """`head` with every metric judged against `base`'s value (verdict `value` = head,
    `baseline` = base), with the tolerances and directions in `baselines`: the stored baseline's
    of head's scenario where it has the metric (hand-set tolerances hold), else the metric's
    default. Criteria and warnings are head's run's own business, as in `kartci compare`: the
    result has none."""
    verdicts = compare_runs(samples(RunFolder(base.folder)), samples(RunFolder(head.folder)),
                            load(baselines / f"{head.name}.json"), alpha)
    return replace(head, verdicts=verdicts, criteria=[], warnings=(), strict_warnings=(),
                   baseline=RunFolder(base.folder).metrics)
