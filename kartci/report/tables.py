"""Formatting shared by every report: numbers with units, deltas, statuses."""

from __future__ import annotations

from dataclasses import dataclass

from kartci.verdict import Conditioning, MetricVerdict, Policy, Status

MARK = {Status.PASS: "✅", Status.IMPROVED: "🟢", Status.REGRESSED: "❌", Status.FAILED: "❌",
        Status.NEW: "🆕", Status.MISSING: "⚠️", Status.ERROR: "💥"}


def num(x: float | None, unit: str = "") -> str:
    """A number to 4 significant digits with its unit (none for bool and fraction); a dash for no
    value."""
    if x is None:
        return "—"
    text = f"{x:.4g}"
    return f"{text} {unit}".strip() if unit and unit not in ("bool", "fraction") else text


def delta(v: MetricVerdict) -> str:
    """The signed change from the baseline to 3 significant digits; a dash when there is none."""
    d = v.delta
    return "—" if d is None else f"{d:+.3g}"


def tolerance(v: MetricVerdict) -> str:
    """The tolerance and the direction it applies in, and the policy bound when the tolerance
    is above it; a dash when there is none."""
    if v.tolerance is None:
        return "—"
    text = f"±{v.tolerance:.3g} ({v.direction.value})"
    if v.policy in (Policy.LOOSENED, Policy.ALLOWED) and v.policy_bound is not None:
        how = "LOOSENED" if v.policy is Policy.LOOSENED else "allowed"
        text += f" {how}: bound ±{v.policy_bound:.3g}"
    return text


def conditioning(v: MetricVerdict) -> str:
    """The metric's spread over replicas started nanometres apart, and what it means for the
    verdict; a dash when the baseline has no replicas."""
    if v.conditioning is Conditioning.UNMEASURED:
        return "—"
    size = "varies" if v.spread is None else f"spread {v.spread:.2g}"
    return {Conditioning.WELL: f"well ({size})",
            Conditioning.MARGINAL: f"marginal ({size}, tolerance widened)",
            Conditioning.ILL: f"ILL-CONDITIONED ({size})"}[v.conditioning]


def regression_size(v: MetricVerdict) -> float:
    """How far past its tolerance a change is (|delta| / tolerance): sorts the worst first.
    A value that vanished, or any change against a zero tolerance, counts as infinite."""
    d = v.delta
    if d is None:
        return 0.0 if v.value is None and v.baseline is None else float("inf")
    if not v.tolerance:
        return float("inf") if d else 0.0
    return abs(d) / v.tolerance


@dataclass(frozen=True)
class Wording:
    """Names in a report: a run judged against baselines, or head compared with base."""

    title: str = "kartci"
    base: str = "baseline"


RUN = Wording()
COMPARE = Wording("kartci compare", "base")
