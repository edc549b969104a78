"""Formatting shared by every report: numbers with units, deltas, statuses; the HTML pages'
style (here, below both the report and the history page that use it)."""

from __future__ import annotations

from dataclasses import dataclass

from kartci.verdict import Conditioning, MetricVerdict, Policy, Status

MARK = {Status.PASS: "✅", Status.IMPROVED: "🟢", Status.REGRESSED: "❌", Status.FAILED: "❌",
        Status.NEW: "🆕", Status.MISSING: "⚠️", Status.ERROR: "💥"}


# the style of every HTML page (report.html, report-static.html, history.html)
CSS = """
body{font-family:system-ui,sans-serif;margin:2em;max-width:1200px;color:#222}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:3px 8px;
text-align:right}th{background:#f3f3f3}td:first-child{text-align:left;font-family:monospace}
.pass,.improved{color:#176f2c}.regressed,.failed,.error,.missing{color:#b00020;font-weight:bold}
.new{color:#555}.cond-ill{color:#b00020;font-weight:bold}.cond-marginal{color:#8a5a00}
.figs{display:flex;flex-wrap:wrap;gap:1em}.figs svg{max-width:560px;height:auto}
.kfigs{display:flex;flex-wrap:wrap;gap:1em}.kfig{width:570px}.ktitle{font-weight:bold;
text-align:center;font-size:14px}.kinfo{font-size:12px}table.laps td.best{font-weight:bold;
color:#176f2c}table.laps tr.ideal td{color:#555;font-style:italic}caption{text-align:left}
section{border-top:2px solid #ddd;margin-top:1.5em}code{background:#f6f6f6;padding:0 3px}
"""


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
