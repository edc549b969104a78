"""The interactive side of report.html: each scenario's figures as JSON, drawn in the browser by
uPlot (vendored in kartci/data/report, MIT, ~50 kB, inlined once per report) and kartci's own
script. uPlot rather than plotly: plotly.js alone is 4.8 MB, a report of the default suite with
uPlot is well under that in all (see docs/howto/report.md)."""

from __future__ import annotations

import html
import json
import math
from functools import cache
from importlib import resources
from typing import Any

import numpy as np

from kartci.plotting import Event, Figure, Series

SIGNIFICANT = 5  # digits kept per value: enough for a cursor read-out, small in the file


def _digits(values: np.ndarray) -> int:
    finite = np.abs(values[np.isfinite(values)])
    top = float(finite.max()) if finite.size else 0.0
    return max(0, SIGNIFICANT - 1 - math.floor(math.log10(top))) if top > 0 else 0


def numbers(values: np.ndarray | None) -> list[float | None] | None:
    """A series' values rounded to SIGNIFICANT digits of its largest; NaN and inf as null."""
    if values is None:
        return None
    v = np.asarray(values, dtype=float)
    rounded = np.round(v, _digits(v))
    return [float(x) if math.isfinite(x) else None for x in rounded]


def _finite(x: float) -> float | None:
    return round(x, 4) if math.isfinite(x) else None


def _series(s: Series) -> dict[str, Any]:
    return {"label": s.label, "role": s.role.value, "x": numbers(s.x), "y": numbers(s.y),
            "t": numbers(s.t), "c": numbers(s.c)}


def _event(e: Event) -> dict[str, Any]:
    return {"label": e.label, "t": _finite(e.t_s), "x": _finite(e.x_m), "y": _finite(e.y_m),
            "lap": _finite(e.lap_m)}


def figure_doc(f: Figure) -> dict[str, Any]:
    """A figure as the browser script reads it."""
    return {"key": f.key, "title": f.title, "xlabel": f.xlabel, "ylabel": f.ylabel,
            "axis": f.axis.value, "log_y": f.log_y, "colour_label": f.colour_label,
            "hlines": list(f.hlines), "ticks": list(f.ticks),
            "series": [_series(s) for s in f.series], "events": [_event(e) for e in f.events]}


def figures_block(scenario: str, figures: list[Figure]) -> str:
    """A scenario's figures: a container the script fills, its data inline as JSON."""
    data = json.dumps({"figures": [figure_doc(f) for f in figures]}, separators=(",", ":"),
                      allow_nan=False).replace("</", "<\\/")
    return (f'<div class="kfigs" data-scenario="{html.escape(scenario)}">'
            f'<script type="application/json">{data}</script></div>')


@cache
def _asset(name: str) -> str:
    return resources.files("kartci").joinpath("data", "report", name).read_text(encoding="utf-8")


def head_assets() -> str:
    """uPlot's stylesheet, for the page's head."""
    return f"<style>{_asset('uPlot.min.css')}</style>"


def body_assets() -> str:
    """uPlot and kartci's figure script, once, at the end of the body."""
    return (f"<script>{_asset('uPlot.iife.min.js')}</script>"
            f"<script>{_asset('kartci-report.js')}</script>")
