"""Baselines: the stored metrics a scenario is judged against, and the comparison rules.

Only `update` writes a baseline file, atomically; a run never does.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping
from dataclasses import dataclass, replace
from enum import StrEnum
from pathlib import Path
from typing import Any

from kartci.atomic import write_json_atomic as write_json_atomic  # re-exported
from kartci.boundedio import RefusedFileError
from kartci.boundedio import is_number as _is_number
from kartci.boundedio import read_json as read_json  # re-exported
from kartci.core import Direction, MetricDef
from kartci.core import definition as registered
from kartci.errors import BaselineError
from kartci.scenario.models import Criterion
from kartci.verdict import criteria
from kartci.verdict.fingerprint import digest


class Status(StrEnum):
    """The verdict on one metric, or on a scenario (the worst of its metrics')."""

    PASS = "pass"
    IMPROVED = "improved"
    REGRESSED = "regressed"
    FAILED = "failed"  # a pass criterion of the scenario is not met
    NEW = "new"  # no baseline value yet
    MISSING = "missing"  # in the baseline, not in the run
    ERROR = "error"  # the run or the metric could not be computed

    @property
    def bad(self) -> bool:
        """True for a status that fails a run (exit code 1 or 2)."""
        return self in (Status.REGRESSED, Status.FAILED, Status.MISSING, Status.ERROR)


class Conditioning(StrEnum):
    """How a metric's baseline spread (its range over replicas started nanometres apart)
    compares with its tolerance: whether its verdict measures the change or chaos."""

    WELL = "well"  # SPREAD_MULTIPLE x spread fits in the tolerance
    MARGINAL = "marginal"  # fits once: judged with the tolerance widened to the multiple
    ILL = "ill"  # the spread alone exceeds the tolerance: the verdict is a coin toss
    UNMEASURED = "unmeasured"  # no replicas were run for this baseline

    @property
    def flagged(self) -> bool:
        """True when the metric is ill-conditioned: a reader must be told."""
        return self is Conditioning.ILL


SPREAD_MULTIPLE = 3.0  # a tolerance below 3 x the chaotic spread could flip on chaos alone


class Policy(StrEnum):
    """A baseline's stored tolerance against the policy bound (`policy_bound`): a tolerance
    widened by hand far beyond what the metric and its chaos need lets regressions through."""

    WITHIN = "within"
    LOOSENED = "loosened"  # above the bound: flagged, and a failure in a strict run
    ALLOWED = "allowed"  # above the bound, allowed by name in the project's configuration
    UNCHECKED = "unchecked"  # no baseline entry, or a metric with no registered default


def conditioning(spread: float | None, declared: float, measured: bool = True) -> Conditioning:
    """A metric's conditioning from its spread (None: defined in some replicas only) and its
    declared tolerance."""
    if not measured:
        return Conditioning.UNMEASURED
    if spread is None or spread > declared:
        return Conditioning.ILL
    return Conditioning.WELL if SPREAD_MULTIPLE * spread <= declared else Conditioning.MARGINAL


def spread(values: list[float | None]) -> float | None:
    """Range of a metric over replicas; 0 when undefined in all, None when undefined in some."""
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if len(finite) != len(values):
        return 0.0 if not finite else None
    return max(finite) - min(finite)


SEVERITY = [Status.ERROR, Status.FAILED, Status.REGRESSED, Status.MISSING, Status.NEW,
            Status.IMPROVED, Status.PASS]


def worst(statuses: list[Status]) -> Status:
    """The most severe status (PASS for none)."""
    return min(statuses, key=SEVERITY.index, default=Status.PASS)


@dataclass(frozen=True)
class MetricVerdict:
    """One metric of a run judged against its baseline value and tolerance."""

    name: str
    value: float | None
    unit: str
    baseline: float | None
    tolerance: float | None
    direction: Direction
    status: Status
    spread: float | None = None  # range over the baseline's replicas (None: see conditioning)
    conditioning: Conditioning = Conditioning.UNMEASURED
    policy: Policy = Policy.UNCHECKED  # the stored tolerance against the policy bound
    policy_bound: float | None = None  # that bound, in the metric's unit

    @property
    def delta(self) -> float | None:
        """value - baseline, or None when either is missing."""
        if self.value is None or self.baseline is None:
            return None
        return self.value - self.baseline


def ill_conditioned(verdicts: list[MetricVerdict]) -> list[str]:
    """One line per ill-conditioned metric: what it is and what to do."""
    out = []
    for v in verdicts:
        if v.conditioning is not Conditioning.ILL:
            continue
        size = "defined in some replicas only" if v.spread is None else f"spread {v.spread:.3g}"
        out.append(f"{v.name} is ill-conditioned ({size} over replicas started nanometres "
                   f"apart, more than its tolerance): its verdict reflects chaos, not the "
                   f"change. Make the scenario or controller decide robustly, or set the "
                   f"tolerance to at least {SPREAD_MULTIPLE:g}x the spread by hand")
    return out


def policy_bound(name: str, entry: Mapping[str, Any], factor: float) -> float | None:
    """The widest tolerance a baseline entry may hold without the project's leave, by the rule
    `judge` widens by: the larger of `factor` x the metric's default tolerance at the baseline
    value and SPREAD_MULTIPLE x its spread; None for a metric with no registered default."""
    d = definition(name)
    if d is None:
        return None
    base = _num(entry.get("value"))
    return max(factor * d.default_tolerance(math.nan if base is None else base),
               SPREAD_MULTIPLE * (_num(entry.get("spread")) or 0.0))


def above(tolerance: float, bound: float) -> bool:
    """A stored tolerance above its policy bound (not on float noise at the bound)."""
    return tolerance > bound * (1 + 1e-9)


def apply_tolerance_policy(verdicts: list[MetricVerdict],
                           baseline: Mapping[str, Mapping[str, Any]] | None, factor: float,
                           allowed: Collection[str]) -> list[MetricVerdict]:
    """Each verdict with its baseline entry's stored tolerance checked against the policy bound
    (`allowed`: metric names the project allows above it)."""
    out = []
    for v in verdicts:
        entry = (baseline or {}).get(v.name)
        bound = None if entry is None else policy_bound(v.name, entry, factor)
        if entry is None or bound is None:
            out.append(v)
            continue
        policy = Policy.WITHIN
        if above(float(entry["tolerance"]), bound):
            policy = Policy.ALLOWED if v.name in allowed else Policy.LOOSENED
        out.append(replace(v, policy=policy, policy_bound=bound))
    return out


def loose_tolerance_messages(verdicts: list[MetricVerdict], label: str, factor: float) -> list[str]:
    """One line per loosened tolerance: which, its bound, and the two ways out."""
    return [f"{v.name}: baseline tolerance {v.tolerance:.3g} is loosened beyond the policy bound "
            f"{v.policy_bound:.3g} (the larger of {factor:g}x its default tolerance and "
            f"{SPREAD_MULTIPLE:g}x its spread); narrow it in the baseline, or allow it in "
            f'[tool.kartci.allow_loose_tolerances] as "{label}:{v.name}" = "<reason>"'
            for v in verdicts if v.policy is Policy.LOOSENED and v.tolerance is not None
            and v.policy_bound is not None]


@dataclass(frozen=True)
class CriterionResult:
    """One pass criterion of a scenario, checked: the value, the bound and whether it holds."""

    name: str
    value: float | None
    bound: str
    ok: bool
    # how far inside its bounds the value is, as a fraction of the bound (of one unit of the
    # metric for a bound of 0): >= 0 holds, < 0 fails; -inf when the value is missing;
    # an `equal` criterion grades nothing while it holds (+inf). What `kartci search` steers by.
    margin: float = math.inf


def _num(x: Any) -> float | None:
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else float(x)


def definition(name: str) -> MetricDef | None:
    """A registered metric's definition, or None."""
    return registered(name)


@dataclass(frozen=True)
class Baseline:
    """A baseline file as read once: its checked metrics and the whole document, whose other
    entries (where it was made, the scenario it was accepted from) judging reads too."""

    path: Path
    metrics: dict[str, dict[str, Any]]
    doc: dict[str, Any]

    @property
    def provenance(self) -> dict[str, Any]:
        """Where it was made (`platform`, `conditioning`); {} for none."""
        return {k: self.doc[k] for k in ("platform", "conditioning")
                if isinstance(self.doc.get(k), dict)}


def read_baseline(path: Path) -> Baseline | None:
    """The baseline at `path`, checked, or None when there is no baseline file. A dangling
    symlink is a broken baseline, not a missing one (that would pass everything as NEW)."""
    if not path.exists():
        if path.is_symlink():
            raise BaselineError(f"{path}: a symlink to a missing file; fix or remove it")
        return None
    try:
        data = read_json(path)
        metrics = data.get("metrics") if isinstance(data, dict) else None
        if not isinstance(metrics, dict):
            raise ValueError('expected {"metrics": {NAME: {...}}}')
        for name, entry in metrics.items():
            if not isinstance(entry, dict):
                raise ValueError(f"{name}: expected a mapping")
            Direction(str(entry.get("direction")))
            tol: Any = entry.get("tolerance")
            if not _is_number(tol) or float(tol) < 0:
                raise ValueError(f"{name}: tolerance must be a number >= 0")
            if entry.get("value") is not None and not _is_number(entry["value"]):
                raise ValueError(f"{name}: value must be a number or null")
            if entry.get("spread") is not None and not (_is_number(entry["spread"])
                                                        and entry["spread"] >= 0):
                raise ValueError(f"{name}: spread must be a number >= 0 or null")
        criteria.check_recorded(data)
    except (OSError, ValueError, UnicodeDecodeError) as err:
        why = err if isinstance(err, RefusedFileError) else f"malformed baseline ({err})"
        raise BaselineError(f"{path}: {why}") from None
    return Baseline(path, dict(metrics), data)


def load(path: Path) -> dict[str, dict[str, Any]] | None:
    """The baseline's metrics by name (`read_baseline`), or None when there is no file."""
    baseline = read_baseline(path)
    return None if baseline is None else baseline.metrics


def judge(value: float | None, unit: str, name: str,
          entry: dict[str, Any] | None) -> MetricVerdict:
    """One metric's value against its baseline entry (None: no baseline, NEW). With a measured
    spread, the tolerance is at least SPREAD_MULTIPLE times it: chaos alone never regresses."""
    d = definition(name)
    direction = Direction(entry["direction"]) if entry else (d.direction if d else
                                                             Direction.EQUAL)
    if entry is None:
        return MetricVerdict(name, value, unit, None, None, direction, Status.NEW)
    base, declared = _num(entry.get("value")), float(entry["tolerance"])
    measured = "spread" in entry
    sp = _num(entry.get("spread"))
    cond = conditioning(sp, declared, measured)
    tol = max(declared, SPREAD_MULTIPLE * sp) if sp is not None else declared
    if value is None and base is None:
        status = Status.PASS
    elif value is None or base is None:
        status = Status.REGRESSED if value is None else Status.IMPROVED
        if direction is Direction.EQUAL:
            status = Status.REGRESSED
    else:
        delta = value - base
        sign = {Direction.LOWER: 1.0, Direction.HIGHER: -1.0, Direction.EQUAL: 0.0}[direction]
        if direction is Direction.EQUAL:
            status = Status.REGRESSED if abs(delta) > tol else Status.PASS
        elif sign * delta > tol:
            status = Status.REGRESSED
        elif sign * delta < -tol:
            status = Status.IMPROVED
        else:
            status = Status.PASS
    return MetricVerdict(name, value, unit, base, tol, direction, status, sp, cond)


def compare(metrics: dict[str, dict[str, Any]],
            baseline: dict[str, dict[str, Any]] | None) -> list[MetricVerdict]:
    """One verdict per metric of the run, plus MISSING for baseline metrics the run lacks."""
    out = [judge(_num(m.get("value")), str(m.get("unit", "")), name,
                 None if baseline is None else baseline.get(name))
           for name, m in sorted(metrics.items())]
    for name, entry in sorted((baseline or {}).items()):
        if name not in metrics:
            out.append(MetricVerdict(name, None, str(entry.get("unit", "")), _num(entry.get(
                "value")), float(entry["tolerance"]), Direction(entry["direction"]),
                Status.MISSING))
    return out


def check_criteria(metrics: dict[str, dict[str, Any]],
                   criteria: dict[str, Criterion]) -> list[CriterionResult]:
    """Each criterion on its metric; with several agents, on every agent's (`agent.name`)."""
    out = []
    for key, c in sorted(criteria.items()):
        names = [key] if key in metrics else sorted(n for n in metrics
                                                     if n.rsplit(".", 1)[-1] == key)
        out += [_criterion(name, c, metrics) for name in names or [key]]
    return out


def _criterion(name: str, c: Criterion, metrics: dict[str, dict[str, Any]]) -> CriterionResult:
    value = _num(metrics.get(name, {}).get("value"))
    parts, ok, margins = [], value is not None, [math.inf]
    if c.max is not None:
        parts.append(f"<= {c.max:g}")
        ok = ok and value is not None and value <= c.max
        margins.append(_margin(c.max - value, c.max) if value is not None else -math.inf)
    if c.min is not None:
        parts.append(f">= {c.min:g}")
        ok = ok and value is not None and value >= c.min
        margins.append(_margin(value - c.min, c.min) if value is not None else -math.inf)
    if c.equal is not None:
        parts.append(f"== {c.equal:g}")
        equal = value is not None and math.isclose(value, c.equal, abs_tol=1e-12)
        ok = ok and equal
        margins.append(math.inf if equal else -math.inf if value is None else
                       _margin(-abs(value - c.equal), c.equal))
    return CriterionResult(name, value, " and ".join(parts), bool(ok), min(margins))


def _margin(room: float, bound: float) -> float:
    """`room` (in the metric's unit) as a fraction of the bound, so that criteria in different
    units compare; a bound of 0 (`line_lost == 0`) scales by one unit of the metric instead."""
    return room / (abs(bound) or 1.0)


@dataclass(frozen=True)
class Change:
    """What a baseline update did to one metric."""

    metric: str
    old: float | None
    new: float | None
    kind: str  # "added", "changed", "removed", "unchanged"


def update(path: Path, scenario: str, metrics: dict[str, dict[str, Any]],
           spreads: dict[str, float | None] | None = None,
           provenance: dict[str, Any] | None = None,
           fields: Mapping[str, Any] | None = None,
           accepted: Mapping[str, Criterion] | None = None) -> list[Change]:
    """Write a scenario's baseline from a run's metrics, keeping hand-set tolerances; with each
    metric's spread over replicas (`spreads`), where it was made (`provenance`: the platform and
    how the replicas were perturbed) and the resolved scenario it was made from (`fields`,
    kartci.verdict.fingerprint, with their hash: a later run of a changed scenario is stale)
    and its pass criteria (`accepted`, kartci.verdict.criteria: a later run tells which were
    added, removed or changed)."""
    old = load(path) or {}
    new: dict[str, dict[str, Any]] = {}
    changes = []
    for name, m in sorted(metrics.items()):
        value = _num(m.get("value"))
        prev = old.get(name)
        d = definition(name)
        if prev is not None and prev.get("value") is not None:
            tol, direction = prev["tolerance"], prev["direction"]  # hand-set: kept
        else:
            tol = d.default_tolerance(value if value is not None else math.nan) if d else 0.0
            direction = (d.direction if d else Direction.EQUAL).value
        new[name] = {"value": value, "unit": m.get("unit", ""), "tolerance": tol,
                     "direction": direction}
        if spreads is not None and name in spreads:
            sp = spreads[name]
            new[name]["spread"] = None if sp is None else float(f"{sp:.4g}")
        old_value = _num(prev.get("value")) if prev else None
        kind = "added" if prev is None else ("unchanged" if old_value == value else "changed")
        changes.append(Change(name, old_value, value, kind))
    changes += [Change(n, _num(e.get("value")), None, "removed") for n, e in old.items()
                if n not in new]
    record = {} if fields is None else {"scenario_hash": digest(fields),
                                        "scenario_fields": dict(fields)}
    if accepted is not None:
        record[criteria.KEY] = criteria.recorded(accepted)
    write_json_atomic(path, {"scenario": scenario, **(provenance or {}), **record, "metrics": new})
    return changes
