"""Formatting shared by every report: numbers with units, deltas, statuses."""

from __future__ import annotations

from kartci.verdict import MetricVerdict, Status

MARK = {Status.PASS: "✅", Status.IMPROVED: "🟢", Status.REGRESSED: "❌", Status.FAILED: "❌",
        Status.NEW: "🆕", Status.MISSING: "⚠️", Status.ERROR: "💥"}


def num(x: float | None, unit: str = "") -> str:
    if x is None:
        return "—"
    text = f"{x:.4g}"
    return f"{text} {unit}".strip() if unit and unit not in ("bool", "fraction") else text


def delta(v: MetricVerdict) -> str:
    d = v.delta
    return "—" if d is None else f"{d:+.3g}"


def tolerance(v: MetricVerdict) -> str:
    return "—" if v.tolerance is None else f"±{v.tolerance:.3g} ({v.direction.value})"
