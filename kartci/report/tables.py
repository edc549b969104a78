"""Formatting shared by every report: numbers with units, deltas, statuses; the HTML pages'
style (here, below both the report and the history page that use it)."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

from kartci.verdict import SEVERITY, Conditioning, MetricVerdict, Policy, Status
from kartci.verdict.result import ScenarioResult


def marked(status: Status) -> str:
    """A status as text that reads at a glance in a terminal, a CI log or Markdown, with no
    emoji font needed: a failing one in capitals (REGRESSED), the others as they are."""
    return status.value.upper() if status.bad else status.value


# Inline SVG icons (16 x 16 view box) drawn beside the status word in HTML: shapes, not emoji,
# so a browser without an emoji font (a stock headless Chromium) shows them; aria-hidden, the
# word beside them says the same.
_CIRCLE = '<circle cx="8" cy="8" r="7.5" fill="{}"/>'
_ICON_SHAPES = {
    Status.PASS: _CIRCLE.format("#176f2c") + '<path d="M4.5 8.3l2.3 2.3 4.7-5" fill="none" '
                 'stroke="#fff" stroke-width="2"/>',
    Status.IMPROVED: _CIRCLE.format("#176f2c") + '<path d="M8 12V4.5M4.8 7.5L8 4.3l3.2 3.2" '
                     'fill="none" stroke="#fff" stroke-width="2"/>',
    Status.REGRESSED: _CIRCLE.format("#b00020") + '<path d="M8 4v7.5M4.8 8.5L8 11.7l3.2-3.2" '
                      'fill="none" stroke="#fff" stroke-width="2"/>',
    Status.FAILED: _CIRCLE.format("#b00020") + '<path d="M5 5l6 6M11 5l-6 6" stroke="#fff" '
                   'stroke-width="2"/>',
    Status.NEW: _CIRCLE.format("#666") + '<path d="M8 4.5v7M4.5 8h7" stroke="#fff" '
                'stroke-width="2"/>',
    Status.MISSING: '<path d="M8 .8L15.4 14.6H.6z" fill="#b36b00"/><path d="M8 5.5v4.5M8 '
                    '11.5v1.6" stroke="#fff" stroke-width="1.8"/>',
    Status.ERROR: '<path d="M4.7 .5h6.6l4.2 4.2v6.6l-4.2 4.2H4.7L.5 11.3V4.7z" fill="#b00020"/>'
                  '<path d="M8 3.5v5.5M8 10.7v1.8" stroke="#fff" stroke-width="2"/>',
}


def icon(status: Status) -> str:
    """A status's inline SVG icon (see _ICON_SHAPES)."""
    return ('<svg class="icon" viewBox="0 0 16 16" width="14" height="14" aria-hidden="true">'
            f"{_ICON_SHAPES[status]}</svg>")


def badge(status: Status) -> str:
    """A status in HTML: its icon and its word, coloured by status."""
    return f'<span class="{status.value}">{icon(status)} {marked(status)}</span>'


def worst_first(results: list[ScenarioResult]) -> list[ScenarioResult]:
    """Scenarios by severity (errors, failures, regressions first), then by how far the worst
    metric went past its tolerance, then by name: what a reader looks for comes first."""
    def key(r: ScenarioResult) -> tuple[int, float, str]:
        worst = max((regression_size(v) for v in r.verdicts if v.status.bad), default=0.0)
        return (SEVERITY.index(r.status), -worst, r.name)
    return sorted(results, key=key)


def verdict_line(results: list[ScenarioResult]) -> str:
    """The run in one line: PASS or FAIL, how many scenarios have which status, and the
    failing ones by name (up to five)."""
    counts = Counter(r.status for r in results)
    tally = ", ".join(f"{counts[s]} {s.value}" for s in SEVERITY if counts[s])
    bad = [r for r in worst_first(results) if r.status.bad]
    if not bad:
        return f"PASS: {len(results)} scenario{'s' * (len(results) != 1)} ({tally or 'none'})"
    names = ", ".join(f"{r.name} ({r.status.value})" for r in bad[:5])
    more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
    return f"FAIL: {len(bad)} of {len(results)} scenarios fail: {names}{more} ({tally})"


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
svg.icon{vertical-align:-2px}p.verdict{font-size:1.2em;font-weight:bold;padding:.4em .6em;
border-left:6px solid}p.verdict.pass{border-color:#176f2c}p.verdict.fail{border-color:#b00020}
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
