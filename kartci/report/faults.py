"""The page of a `kartci faults` (OUT/faults.html): the detection matrix as a heat map (faults x
scenarios: caught, missed, not applicable, error), the scores, and every cell with the metrics
that caught it or why not. Drawn from summary.json's content alone, so the page and the file
never disagree; the figure is inline SVG (matplotlib) and the page opens offline like the run
report."""

from __future__ import annotations

import html
from typing import Any

import matplotlib.pyplot as plt
from matplotlib.colors import ListedColormap
from matplotlib.patches import Patch

from kartci.plotstyle import svg  # also sets Agg and the SVG settings
from kartci.report.tables import CSS

# the five results of a cell, in the heat map's colour order
RESULTS = ("caught", "missed", "no effect", "not applicable", "error")
_COLOURS = ("#176f2c", "#b00020", "#c9a227", "#d9d9d9", "#6a1b9a")
_MARKS = {"caught": "✓", "missed": "✗", "no effect": "=", "not applicable": "", "error": "!"}


def _score(entry: dict[str, Any]) -> str:
    if not entry.get("judged"):
        return "-"
    return f"{entry['caught']}/{entry['judged']}"


def heat_map(summary: dict[str, Any]) -> str:
    """Faults (rows) x scenarios (columns), each cell coloured by its result, with each
    scenario's and each fault's score on its label."""
    faults = summary["faults"]
    scenarios = summary["scenarios"]
    row = {f["name"]: i for i, f in enumerate(faults)}
    col = {s["name"]: j for j, s in enumerate(scenarios)}
    grid = [[RESULTS.index("not applicable")] * len(scenarios) for _ in faults]
    for c in summary["cells"]:
        grid[row[c["fault"]]][col[c["scenario"]]] = RESULTS.index(c["result"])
    labels = max((len(f["name"]) for f in faults), default=0) * 0.075  # inches of row labels
    fig, ax = plt.subplots(figsize=(min(labels + 3.0 + 0.6 * len(scenarios), 20.0),
                                    min(2.6 + 0.3 * len(faults), 24.0)))
    ax.imshow(grid, cmap=ListedColormap(_COLOURS), vmin=-0.5, vmax=len(RESULTS) - 0.5,
              aspect="auto", interpolation="nearest")
    for c in summary["cells"]:
        mark = _MARKS[c["result"]]
        if mark:
            ax.text(col[c["scenario"]], row[c["fault"]], mark, ha="center", va="center",
                    color="white", fontsize=9)
    ax.set_xticks(range(len(scenarios)),
                  [f"{s['name']}  {_score(s)}" for s in scenarios], rotation=45, ha="right",
                  fontsize=8)
    ax.set_yticks(range(len(faults)), [f"{f['name']}  {_score(f)}" for f in faults],
                  fontsize=8)
    ax.set_xticks([x - 0.5 for x in range(1, len(scenarios))], minor=True)
    ax.set_yticks([y - 0.5 for y in range(1, len(faults))], minor=True)
    ax.grid(which="minor", color="white", linewidth=1.5)
    ax.tick_params(which="minor", length=0)
    total = summary["score"]
    ax.set_title(f"detection matrix: suite score {_score(total)}"
                 + (f" ({total['score']:.0%})" if total.get("score") is not None else ""))
    ax.legend(handles=[Patch(color=c, label=r) for c, r in zip(_COLOURS, RESULTS, strict=True)],
              loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return svg(fig)


def faults_page(summary: dict[str, Any]) -> str:
    """The whole page."""
    total = summary["score"]
    pct = "" if total.get("score") is None else f" ({total['score']:.0%})"
    verdict = "pass" if total.get("judged") and total["caught"] == total["judged"] else "fail"
    parts = [f'<p class="verdict {verdict}">The suite catches {total["caught"]} of the '
             f"{total['judged']} faults it was judged on{pct}"
             + (f"; {total['no_effect']} had no effect on any metric and are not scored"
                if total.get("no_effect") else "") + ".</p>",
             f"<p><code>{html.escape(summary['command'])}</code>: each scenario run as written "
             "and once under each fault of the catalogue that acts on it; each faulted run "
             "judged against the scenario's own run with its baseline's tolerances, as "
             "<code>kartci compare</code> judges. Caught: the gate would fail. No effect: no "
             "metric moved beyond its resolution (a tenth of its default tolerance), so no "
             "gate could fail. No-effect and not-applicable faults and failed runs are not "
             "scored.</p>"]
    if summary["faults"] and summary["scenarios"]:
        parts.append(f'<div class="figs">{heat_map(summary)}</div>')
    parts.append("<h2>Scenarios</h2><table><tr><th>scenario</th><th>nominal run vs its "
                 "baseline</th><th>caught / judged</th></tr>")
    parts += [f"<tr><td><a href=\"{html.escape(s['name'])}/\">{html.escape(s['name'])}</a>"
              f"</td><td>{html.escape(str(s.get('nominal') or '-'))}</td>"
              f"<td>{_score(s)}</td></tr>" for s in summary["scenarios"]]
    parts.append("</table><h2>Faults</h2><table><tr><th>fault</th><th>declared by</th>"
                 "<th>what</th><th>caught / judged</th></tr>")
    parts += [f"<tr><td>{html.escape(f['name'])}</td><td>{html.escape(f['scope'])} "
              f"{html.escape(f['owner'])}</td><td>{html.escape(f['description'])}</td>"
              f"<td>{_score(f)}</td></tr>" for f in summary["faults"]]
    parts.append("</table><h2>Cells</h2><table><tr><th>fault</th><th>scenario</th>"
                 "<th>result</th><th>caught by / why</th></tr>")
    for c in summary["cells"]:
        if c["result"] == "not applicable":
            continue
        result = html.escape(c["result"])
        if c.get("run"):
            result = f'<a href="{html.escape(c["run"])}/">{result}</a>'
        css = {"caught": "pass", "missed": "failed", "no effect": "new",
               "error": "error"}[c["result"]]
        why = "<br>".join(html.escape(x) for x in c["caught_by"]) or html.escape(c["why"])
        parts.append(f"<tr><td>{html.escape(c['fault'])}</td><td>{html.escape(c['scenario'])}"
                     f'</td><td class="{css}">{result}</td><td>{why}</td></tr>')
    parts.append("</table><h2>Not applicable</h2><ul>")
    parts += [f"<li>{html.escape(c['fault'])} on {html.escape(c['scenario'])}: "
              f"{html.escape(c['why'])}</li>" for c in summary["cells"]
              if c["result"] == "not applicable"]
    parts.append("</ul>")
    title = "kartci faults: detection matrix"
    return (f'<!doctype html><html><head><meta charset="utf-8"><title>{title}</title>'
            f"<style>{CSS}</style></head><body><h1>{title}</h1>" + "".join(parts)
            + "</body></html>\n")
