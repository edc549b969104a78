"""The lap table of a kart run: every complete lap, its three sectors, the best of each marked,
and the ideal lap (the sum of the best sectors)."""

from __future__ import annotations

import html

import pandas as pd

from kartci.plotting import Plots


def _s(x: float) -> str:
    return f"{x:.3f} s"  # to the millisecond: laps differ in the third digit


def _table(agent: str, laps: pd.DataFrame) -> str:
    cols = [c for c in laps.columns if c != "lap"]
    best = {c: laps[c].min() for c in cols}
    head = "".join(f"<th>{'lap time' if c == 'time_s' else 'sector ' + c[1]}</th>" for c in cols)
    rows = []
    for _, row in laps.iterrows():
        cells = "".join(
            f'<td class="{"best" if row[c] == best[c] else ""}">{_s(float(row[c]))}</td>'
            for c in cols)
        rows.append(f"<tr><td>{int(row['lap'])}</td>{cells}</tr>")
    sectors = [c for c in cols if c != "time_s"]
    ideal = sum(float(best[c]) for c in sectors)
    rows.append(f'<tr class="ideal"><td>ideal</td><td>{_s(ideal)}</td>'
                + "".join(f"<td>{_s(float(best[c]))}</td>" for c in sectors) + "</tr>")
    return (f'<table class="laps"><caption>{html.escape(agent)}: laps (best in bold; ideal lap = '
            f"best sectors added up)</caption><tr><th>lap</th>{head}</tr>{''.join(rows)}</table>")


def lap_tables(p: Plots) -> str:
    """One lap table per agent with complete laps; a line saying so for one with none."""
    out = []
    for agent, laps in p.laps.items():
        if laps.empty:
            out.append(f"<p>{html.escape(agent)}: no complete lap.</p>")
        else:
            out.append(_table(agent, laps))
    return "".join(out)
