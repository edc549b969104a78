"""The page of a `kartci search` (OUT/search.html): the explored space with each run's margin
against its criteria, the failure found and its boundary, and every run in a table. Figures are
inline SVG (matplotlib), so the page opens offline from a CI artifact like the run report."""

from __future__ import annotations

import html
import math
from collections.abc import Callable

import matplotlib.pyplot as plt
from matplotlib.axes import Axes
from matplotlib.colors import TwoSlopeNorm

from kartci.plotstyle import svg  # also sets Agg and the SVG settings
from kartci.report.tables import CSS, num
from kartci.runner.search import CLIP, Axis, AxisKind, Evaluation, Found, RunStatus

_COLOUR = {RunStatus.PASS: "#176f2c", RunStatus.FAIL: "#b00020", RunStatus.ERROR: "#6a1b9a"}


def _y(e: Evaluation, found: Found) -> float:
    """What a run scores on the page: its margin (clipped to +-CLIP), or the objective."""
    if found.plan.objective is not None:
        return math.nan if e.value is None else e.value
    return max(-CLIP, min(CLIP, e.margin)) if not math.isnan(e.margin) else math.nan


def _coord(axis: Axis, value: str) -> float:
    return axis.position(value) if axis.kind is AxisKind.CHOICE else float(value)


def _ticks(ax: Axes, axis: Axis, which: str) -> None:
    if axis.kind is AxisKind.CHOICE:
        getattr(ax, f"set_{which}ticks")(range(len(axis.choices)), axis.choices)


def _one_axis(found: Found) -> str:
    """Margin (or objective) against the axis; the boundary as a shaded band."""
    axis = found.plan.axes[0]
    fig, ax = plt.subplots(figsize=(6.5, 3.6))
    runs = [e for e in found.counted if not math.isnan(_y(e, found))]
    for status, colour in _COLOUR.items():
        mine = [e for e in runs if e.status is status]
        if mine:
            ax.scatter([_coord(axis, e.point[0][1]) for e in mine], [_y(e, found) for e in mine],
                       c=colour, s=22, label=f"{status.value} ({len(mine)})", zorder=3)
    if found.plan.objective is None:
        ax.axhline(0.0, color="grey", lw=0.8, ls="--")
    for b in found.brackets:
        lo, hi = sorted((_coord(axis, b.passing), _coord(axis, b.failing)))
        ax.axvspan(lo, hi, color="orange", alpha=0.35, label=f"boundary {b.passing}..{b.failing}")
    _mark(ax, found, lambda e: (_coord(axis, e.point[0][1]), _y(e, found)),
          (_coord(axis, axis.nominal), None))
    _ticks(ax, axis, "x")
    ax.set_xlabel(axis.key)
    ax.set_ylabel(found.plan.objective or "smallest criterion margin (fraction of bound)")
    ax.set_title("runs of the search" + ("" if found.plan.objective else "; < 0: failed"))
    ax.legend(loc="best", fontsize=8)
    return svg(fig)


def _two_axes(found: Found, i: int, j: int) -> str:
    """Two axes as a plane, each run coloured by its margin (red fails, green passes)."""
    a, b = found.plan.axes[i], found.plan.axes[j]
    fig, ax = plt.subplots(figsize=(6.5, 5.0))
    runs = [e for e in found.counted if not math.isnan(_y(e, found))]
    xs = [_coord(a, e.point[i][1]) for e in runs]
    ys = [_coord(b, e.point[j][1]) for e in runs]
    cs = [_y(e, found) for e in runs]
    if runs:
        if found.plan.objective is None:
            span = max(1e-9, max(abs(c) for c in cs))
            norm = TwoSlopeNorm(0.0, -span, span)
            cmap = "RdYlGn"
        else:
            lo, hi = min(cs), max(cs)
            norm, cmap = TwoSlopeNorm((lo + hi) / 2, lo - 1e-12, hi + 1e-12), (
                "viridis_r" if found.plan.higher_is_worse else "viridis")
        sc = ax.scatter(xs, ys, c=cs, cmap=cmap, norm=norm, s=30, edgecolors="black",
                        linewidths=[1.2 if e.status.failing else 0.2 for e in runs], zorder=3)
        fig.colorbar(sc, ax=ax, label=found.plan.objective or "margin (< 0: failed)")
    shrunk = found.failure
    for bracket in found.brackets:
        if shrunk is None:
            continue
        k = [ax_.key for ax_ in found.plan.axes].index(bracket.key)
        if k not in (i, j):
            continue
        p, f = dict(shrunk.point), dict(shrunk.point)
        p[bracket.key] = bracket.passing
        ends = [(_coord(a, pt[a.key]), _coord(b, pt[b.key])) for pt in (p, f)]
        ax.plot(*zip(*ends, strict=True), color="orange", lw=4, alpha=0.8,
                label=f"boundary on {bracket.key}", zorder=4)
    _mark(ax, found, lambda e: (_coord(a, e.point[i][1]), _coord(b, e.point[j][1])),
          (_coord(a, a.nominal), _coord(b, b.nominal)))
    _ticks(ax, a, "x")
    _ticks(ax, b, "y")
    ax.set_xlabel(a.key)
    ax.set_ylabel(b.key)
    ax.set_title("runs of the search (outlined: failed)")
    ax.legend(loc="best", fontsize=8)
    return svg(fig)


def _mark(ax: Axes, found: Found, where: Callable[[Evaluation], tuple[float, float]],
          nominal: tuple[float, float | None]) -> None:
    """The nominal (a vertical line on one axis, a plus on a plane) and the found run."""
    if nominal[1] is None:
        ax.axvline(nominal[0], color="black", lw=0.8, ls=":", label="scenario's own value")
    else:
        ax.scatter([nominal[0]], [nominal[1]], marker="P", s=90, c="black",
                   label="scenario's own values", zorder=5)
    if found.failure is not None:
        x, y = where(found.failure)
        ax.scatter([x], [y], marker="*", s=220, c="gold", edgecolors="black", zorder=6,
                   label="found" if found.plan.objective is None else "worst")


def search_page(found: Found, scenario: str, command: str, found_yaml: str | None) -> str:
    """The whole page."""
    plan = found.plan
    runs = found.counted
    e = found.failure
    if plan.objective is None and e is not None and e.status.failing:
        head = (f"FAIL found at {html.escape(_values(e))}: {html.escape('; '.join(e.why))}")
        verdict = "fail"
    elif plan.objective is not None and e is not None:
        head = f"worst {html.escape(plan.objective)} {num(e.value)} at {html.escape(_values(e))}"
        verdict = "fail" if any(r.status.failing for r in runs) else "pass"
    else:
        small = found.smallest
        head = (f"no failure in {len(runs)} runs; covered {found.coverage:.0%} of the space; "
                f"smallest margin {num(small.margin if small else None)}"
                + (f" at {html.escape(_values(small))}" if small else ""))
        verdict = "pass"
    parts = [f"<p class=\"verdict {verdict}\">{head}</p>",
             f"<p><code>{html.escape(command)}</code>: {len(runs)} runs of {plan.budget}, "
             f"covering {found.covered} of {found.cells} cells of the space "
             f"({found.coverage:.0%}).</p>"]
    if plan.objective is None and e is not None and e.status.failing and not found.shrunk:
        parts.append("<p>The budget ran out while shrinking: a failure nearer the scenario's "
                     "own values may exist (a larger <code>--budget</code> resumes it).</p>")
    if found_yaml:
        parts.append(f'<p>As a scenario: <a href="{html.escape(found_yaml)}">'
                     f"{html.escape(found_yaml)}</a> (<code>kartci run "
                     f"{html.escape(found_yaml)}</code> runs it).</p>")
    if found.brackets:
        parts.append("<h2>Boundary</h2><table><tr><th>key</th><th>passes at</th>"
                     "<th>fails at</th><th>scenario's own</th></tr>")
        own = dict(plan.nominal)
        parts += [f"<tr><td>{html.escape(b.key)}</td><td>{html.escape(b.passing)}</td>"
                  f"<td>{html.escape(b.failing)}</td><td>{html.escape(own[b.key])}</td></tr>"
                  for b in found.brackets]
        parts.append("</table>")
    parts.append('<h2>Explored space</h2><div class="figs">')
    if len(plan.axes) == 1:
        parts.append(_one_axis(found))
    else:
        parts += [_two_axes(found, i, i + 1) for i in range(0, len(plan.axes) - 1, 2)]
        if len(plan.axes) % 2:
            parts.append(_two_axes(found, len(plan.axes) - 2, len(plan.axes) - 1))
    parts.append("</div><h2>Runs</h2><table><tr><th>#</th><th>phase</th>"
                 + "".join(f"<th>{html.escape(a.key)}</th>" for a in plan.axes)
                 + "<th>margin</th>" + (f"<th>{html.escape(plan.objective)}</th>"
                                        if plan.objective else "")
                 + "<th>result</th><th>why</th></tr>")
    for n, r in enumerate(found.runs, 1):
        link = (f'<a href="{html.escape(r.label)}/">{r.status.value}</a>' if r.label
                else r.status.value)
        parts.append(f"<tr><td>{n}</td><td>{r.phase.value}</td>"
                     + "".join(f"<td>{html.escape(v)}</td>" for _, v in r.point)
                     + f"<td>{num(r.margin) if math.isfinite(r.margin) else '—'}</td>"
                     + (f"<td>{num(r.value)}</td>" if plan.objective else "")
                     + f'<td class="{"failed" if r.status.failing else r.status.value}">'
                     f"{link}</td><td>{html.escape('; '.join(r.why))}</td></tr>")
    parts.append("</table>")
    title = f"kartci search: {scenario}"
    return (f'<!doctype html><html><head><meta charset="utf-8"><title>{html.escape(title)}'
            f"</title><style>{CSS}</style></head><body><h1>{html.escape(title)}</h1>"
            + "".join(parts) + "</body></html>\n")


def _values(e: Evaluation) -> str:
    return ", ".join(f"{k}={v}" for k, v in e.point)
