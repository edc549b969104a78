"""The self-contained HTML report: verdict table per scenario and its plots, inline."""

from __future__ import annotations

import html
from datetime import UTC, datetime
from typing import Any

from kartci.report.figures import scenario_figures
from kartci.report.history import history_sections
from kartci.report.interactive import body_assets, figures_block, head_assets
from kartci.report.laps import lap_tables
from kartci.report.markdown import VERDICT_WORD
from kartci.report.tables import (
    CSS,
    RUN,
    Wording,
    badge,
    conditioning,
    delta,
    num,
    tolerance,
    verdict_line,
    worst_first,
)
from kartci.verdict import Status
from kartci.verdict.result import ScenarioResult, exit_code

HELP = ("<p>Figures: hover to read values (the time cursor is shared by a scenario's plots and "
        "shown as a dot on the view from above), wheel to zoom, drag to zoom to a range, "
        "shift+drag to pan, double-click to reset. Dashed grey: the baseline's reference "
        "trace; red dotted lines and crosses: collisions and solver failures.")
STATIC_LINK = ' <a href="report-static.html">Static version</a> (no script).'  # when written


def _scenario(r: ScenarioResult, words: Wording, static: bool) -> str:
    out = [f'<section id="{html.escape(r.name)}"><h2>{html.escape(r.name)} '
           f'{badge(r.status)}</h2>',
           f"<p>{html.escape(r.description)}</p>"]
    if r.error:
        out.append(f'<p class="error">{html.escape(r.error)}</p></section>')
        return "\n".join(out)
    out += [f'<p class="failed">{html.escape(x)}</p>' for x in r.problems]
    out += [f'<p class="missing">warning: {html.escape(x)}</p>' for x in r.warnings]
    if r.run:
        out.append(f"<p>sim time {num(r.run.get('sim_time_s'), 's')}, wall "
                   f"{num(r.run.get('wall_s'), 's')}, real-time factor "
                   f"{num(r.run.get('real_time_factor'))}; log <code>"
                   f"{html.escape(str(r.run.get('log', '')))}</code></p>")
    out.append(f"<table><tr><th>metric</th><th>value</th><th>{words.base}</th><th>delta</th>"
               "<th>tolerance</th><th>conditioning</th><th>verdict</th></tr>")
    for v in sorted(r.verdicts, key=lambda v: not v.status.bad):  # failing metrics first
        out.append(f"<tr><td>{html.escape(v.name)}</td><td>{num(v.value, v.unit)}</td>"
                   f"<td>{num(v.baseline, v.unit)}</td><td>{delta(v)}</td>"
                   f"<td>{tolerance(v)}</td><td class=\"cond-{v.conditioning.value}\">"
                   f"{conditioning(v)}</td><td>{badge(v.status)}</td></tr>")
    out.append("</table>")
    if r.criteria:
        out.append("<table><tr><th>criterion</th><th>bound</th><th>value</th><th>result</th>"
                   "</tr>")
        for c in sorted(r.criteria, key=lambda c: c.ok):  # failed criteria first
            out.append(f"<tr><td>{html.escape(c.name)}</td><td>{html.escape(c.bound)}</td>"
                       f"<td>{num(c.value)}</td><td>"
                       f"{badge(Status.PASS if c.ok else Status.FAILED)}</td></tr>")
        out.append("</table>")
    if r.plots is not None:
        out.append(lap_tables(r.plots))
        if static:
            from kartci.report.static import scenario_svgs  # start-up: matplotlib (~0.5 s)

            svgs = r.static_figures if r.static_figures is not None else scenario_svgs(r.plots)
            out.append('<div class="figs">' + "".join(svgs) + "</div>")
        else:
            out.append(figures_block(r.name, scenario_figures(r.plots)))
    out.append("</section>")
    return "\n".join(out)


def _history(results: list[ScenarioResult], history: tuple[list[str], Any]) -> str:
    """The metric history of this run's scenarios, the run itself as the newest point."""
    labels, values = history
    return (f'<section id="metric-history"><h2>Metric history</h2><p>{len(labels) - 1} earlier '
            "commits of main, then this run (hover a point for its commit).</p>"
            f"{history_sections(labels, values, {r.name for r in results}, level=3)}</section>")


def report_html(results: list[ScenarioResult], words: Wording = RUN,
                static: bool = False, history: tuple[list[str], Any] | None = None,
                static_page: bool = True) -> str:
    """report.html, self-contained and offline: the verdict, a table of scenarios, and each
    scenario's metrics, criteria, lap tables and figures: interactive (uPlot, inlined once), or
    `static` SVG with no script (report-static.html, for e-mail; `static_page`: one is written
    beside, linked). Scenarios come worst first, in the index and in the sections, under a
    one-line verdict."""
    code = exit_code(results)
    results = worst_first(results)
    rows = "".join(f'<tr><td><a href="#{html.escape(r.name)}">{html.escape(r.name)}</a></td>'
                   f"<td>{badge(r.status)}</td></tr>" for r in results)
    verdict = verdict_line(results)
    stamp = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    body = "\n".join(_scenario(r, words, static) for r in results)
    if history is not None and not static:
        body += _history(results, history)
    title = f"{words.title} report"
    return (f"<!doctype html><html><head><meta charset=\"utf-8\"><title>{html.escape(title)}"
            f"</title><style>{CSS}</style>{'' if static else head_assets()}</head><body>"
            f"<h1>{html.escape(title)}: "
            f"{VERDICT_WORD[code]}</h1>"
            f'<p class="verdict {verdict[:4].lower()}">{html.escape(verdict)}</p>'
            f"<p>written {stamp}; exit code {code}</p>"
            f"<table><tr><th>scenario</th><th>status</th></tr>{rows}</table>"
            f"{'' if static else HELP + (STATIC_LINK if static_page else '') + '</p>'}"
            f"{body}{'' if static else body_assets()}</body></html>\n")
