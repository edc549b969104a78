"""Metric history across commits, asv-style: each commit's merged summary.json (kept by CI on the
`kartci-history` branch) becomes one point per metric, drawn per scenario in history.html with
the same interactive figures as the report (hover names the commit)."""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

import numpy as np

from kartci.atomic import check_target, write_text_atomic
from kartci.boundedio import JSON_MAX_BYTES, RefusedFileError, out_of_range, read_bytes
from kartci.errors import SpecError
from kartci.plotting import Axis, Figure, Series
from kartci.report.interactive import body_assets, figures_block, head_assets
from kartci.report.tables import CSS
from kartci.scenario.yamlio import clip

History = dict[str, dict[str, list[float | None]]]  # scenario -> metric -> value per commit


def load_summary(path: Path) -> dict[str, Any]:
    """One commit's summary.json (a regular file within JSON_MAX_BYTES, every number a float
    can hold); anything else is a SpecError naming the file."""
    try:
        doc = json.loads(read_bytes(path, JSON_MAX_BYTES))
        if not isinstance(doc["scenarios"], dict):
            raise TypeError("scenarios is not a mapping")
    except FileNotFoundError:
        raise SpecError(f"{path}: file not found") from None
    except RefusedFileError as err:
        raise SpecError(f"{path}: {err}") from None
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as err:
        why = "nested too deeply" if isinstance(err, RecursionError) else clip(str(err))
        raise SpecError(f"{path}: not a kartci summary.json ({why})") from None
    field = out_of_range(doc)
    if field is not None:
        raise SpecError(f"{path}: {field}: a number out of range (beyond a float's ±1.8e308)")
    return dict(doc)


def collect(docs: list[tuple[str, dict[str, Any]]]) -> tuple[list[str], History]:
    """Commit labels and every metric's value per commit, from (label, summary) pairs, oldest
    first; a metric a commit lacks, or a failed scenario, is a gap."""
    history: History = {}
    for i, (_, doc) in enumerate(docs):
        for name, sc in doc["scenarios"].items():
            metrics = sc.get("metrics") if isinstance(sc, dict) else None
            for metric, entry in (metrics or {}).items():
                value = entry.get("value") if isinstance(entry, dict) else None
                column = history.setdefault(name, {}).setdefault(metric, [None] * len(docs))
                column[i] = float(value) if isinstance(value, int | float) else None
    return [label for label, _ in docs], history


def read_summaries(paths: list[Path]) -> tuple[list[str], History]:
    """Commit labels (file stems, in the order given) and every metric's value per commit."""
    return collect([(p.stem, load_summary(p)) for p in paths])


def history_figures(labels: list[str], metrics: dict[str, list[float | None]]) -> list[Figure]:
    """One figure per metric of a scenario: its value at each commit (x: commit index)."""
    x = np.arange(len(labels), dtype=float)
    return [Figure(f"history_{metric}", metric, "commit (oldest to newest)", metric,
                   Axis.COMMIT, [Series(metric, x, np.array(
                       [np.nan if v is None else v for v in values], dtype=float))],
                   ticks=tuple(labels))
            for metric, values in sorted(metrics.items())]


def history_sections(labels: list[str], history: History, only: set[str] | None = None,
                     level: int = 2) -> str:
    """A section per scenario (those in `only`, if given) with its metrics over the commits."""
    return "".join(
        f'<section id="history-{html.escape(name)}"><h{level}>{html.escape(name)}</h{level}>'
        f"{figures_block(f'history {name}', history_figures(labels, metrics))}</section>"
        for name, metrics in sorted(history.items()) if only is None or name in only)


def history_html(labels: list[str], history: History) -> str:
    """history.html: every scenario's metrics over the commits, self-contained."""
    body = history_sections(labels, history)
    return (f'<!doctype html><html><head><meta charset="utf-8"><title>kartci history</title>'
            f"<style>{CSS}</style>{head_assets()}</head><body><h1>kartci metric history</h1>"
            f"<p>{len(labels)} commits, oldest {html.escape(labels[0] if labels else '-')}, "
            f"newest {html.escape(labels[-1] if labels else '-')}; hover a point for its commit."
            f"</p>{body}{body_assets()}</body></html>\n")


def write_history(paths: list[Path], out: Path) -> Path:
    """Read the summaries and write OUT/history.html; returns its path."""
    if not paths:
        raise SpecError("kartci history: name at least one summary.json")
    target = out / "history.html"
    check_target(target)  # before the summaries are read
    labels, history = read_summaries(paths)
    write_text_atomic(target, history_html(labels, history))
    return target


__all__ = ["History", "collect", "history_figures", "history_html", "history_sections",
           "load_summary", "read_summaries", "write_history"]
