"""Head against base: the baseline rules applied to two runs, with asv's significance rule.

Each side may hold K samples of a metric (`kartci run --repeat K`: seeds seed .. seed+K-1). The
medians are judged with the metric's tolerance and direction exactly as a run is judged against
its baseline; a change beyond the tolerance then counts only when it is also significant
across the samples (asv): a two-sided Mann-Whitney U test at `alpha` when the sample sizes can
reach that level, otherwise non-overlapping ranges. With one sample on a side there is no
spread to test and the tolerance alone decides.
"""

from __future__ import annotations

import math
import statistics
from dataclasses import replace
from typing import Any

from scipy.stats import mannwhitneyu

from kartci.verdict.baseline import MetricVerdict, Status, compare, definition

ALPHA = 0.05
Samples = dict[str, dict[str, Any]]  # metric -> {"unit": str, "values": [float | None, ...]}


def significant(a: list[float], b: list[float], alpha: float = ALPHA) -> bool:
    """asv's rule: Mann-Whitney U when it can reach `alpha`, else non-overlapping ranges."""
    if len(a) < 2 or len(b) < 2:
        return True
    if 1 / math.comb(len(a) + len(b), min(len(a), len(b))) < alpha:
        return bool(mannwhitneyu(a, b, alternative="two-sided").pvalue < alpha)
    return max(a) < min(b) or max(b) < min(a)


def _finite(values: list[Any]) -> list[float]:
    return [float(v) for v in values if v is not None and math.isfinite(v)]


def _median(values: list[Any]) -> float | None:
    finite = _finite(values)
    return statistics.median(finite) if len(finite) == len(values) and finite else None


def compare_runs(base: Samples, head: Samples, baseline: dict[str, dict[str, Any]] | None,
                 alpha: float = ALPHA) -> list[MetricVerdict]:
    """One verdict per metric: `value` is head's median, `baseline` base's. Tolerance and
    direction come from the stored baseline when it has the metric (hand-set tolerances hold
    here too), else from the metric's definition."""
    entries = {}
    for name, s in base.items():
        value = _median(s["values"])
        stored = (baseline or {}).get(name)
        d = definition(name)
        if stored is not None:
            tol, direction = float(stored["tolerance"]), str(stored["direction"])
        elif d is not None:
            tol = d.default_tolerance(value if value is not None else math.nan)
            direction = d.direction.value
        else:
            tol, direction = 0.0, "equal"
        entries[name] = {"value": value, "unit": s["unit"], "tolerance": tol,
                         "direction": direction}
    values = {name: {"value": _median(s["values"]), "unit": s["unit"]}
              for name, s in head.items()}
    out = []
    for v in compare(values, entries):
        if v.status in (Status.REGRESSED, Status.IMPROVED) and v.name in base and (
                v.name in head):
            a, b = _finite(base[v.name]["values"]), _finite(head[v.name]["values"])
            if a and b and not significant(a, b, alpha):
                v = replace(v, status=Status.PASS)
        out.append(v)
    return out
