"""Reference traces: a compact, decimated copy of a baseline run's path (time, position, speed,
cross-track error, progress) stored beside the baseline's numbers, so a gating run's report can
overlay the current run on the baseline's without a second run. Traces are for reading only:
no verdict or metric ever reads one."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from kartci.atomic import write_text_atomic
from kartci.boundedio import JSON_MAX_BYTES, read_bytes
from kartci.errors import BaselineError
from kartci.plotting import Plots

STEP_S = 0.2  # one sample per 0.2 s of sim time: a 50 s lap run is ~250 rows, ~15 kB
COLUMNS = {"t": 3, "x": 3, "y": 3, "speed": 3, "offset": 5, "s_total": 2}  # name -> decimals
VERSION = 1


def trace_path(baselines: Path, label: str) -> Path:
    """Where a scenario's reference trace lives: `baselines/traces/<label>.json`."""
    return baselines / "traces" / f"{label}.json"


def decimate(frame: pd.DataFrame, step_s: float = STEP_S) -> pd.DataFrame:
    """The first row at or after each multiple of `step_s` from the frame's start, and its last."""
    t = frame["t"].to_numpy(dtype=float)
    if len(t) == 0:
        return frame.iloc[:0]
    grid = np.arange(t[0], t[-1], step_s)
    rows = np.unique(np.append(np.searchsorted(t, grid), len(t) - 1))
    return frame.iloc[rows]


def make_trace(plots: Plots, step_s: float = STEP_S) -> dict[str, Any]:
    """The trace document of a run: per agent, its decimated path columns, rounded."""
    agents: dict[str, dict[str, list[float]]] = {}
    for agent, frame in plots.tracks.items():
        small = decimate(frame, step_s)
        agents[agent] = {c: [round(float(v), d) if math.isfinite(v) else 0.0
                             for v in small[c].to_numpy(dtype=float)]
                         for c, d in COLUMNS.items() if c in small}
    return {"version": VERSION, "kind": plots.kind, "step_s": step_s, "agents": agents}


def trace_text(doc: dict[str, Any]) -> str:
    """JSON with one line per column: small, and a changed trace diffs by column."""
    lines = [f'{{"version": {doc["version"]}, "kind": {json.dumps(doc["kind"])}, '
             f'"step_s": {doc["step_s"]!r}, "agents": {{']
    agents = sorted(doc["agents"].items())
    for i, (agent, cols) in enumerate(agents):
        lines.append(f"  {json.dumps(agent)}: {{")
        names = sorted(cols)
        lines += [f"    {json.dumps(c)}: {json.dumps(cols[c])}{',' if j < len(names) - 1 else ''}"
                  for j, c in enumerate(names)]
        lines.append("  }" + ("," if i < len(agents) - 1 else ""))
    return "\n".join([*lines, "}}"]) + "\n"


def write_trace(path: Path, plots: Plots) -> int:
    """Store a run's reference trace at `path`; returns its size in bytes."""
    text = trace_text(make_trace(plots))
    write_text_atomic(path, text)
    return len(text.encode("utf-8"))


def load_trace(path: Path) -> dict[str, pd.DataFrame]:
    """The reference trace by agent ({} when there is none); a malformed file is a
    BaselineError naming it."""
    if not path.is_file():
        return {}
    try:
        doc = json.loads(read_bytes(path, JSON_MAX_BYTES))
        if not isinstance(doc, dict) or doc.get("version") != VERSION:
            raise ValueError(f"expected a version {VERSION} trace document")
        out = {}
        for agent, cols in doc["agents"].items():
            frame = pd.DataFrame({c: np.asarray(v, dtype=float) for c, v in cols.items()})
            if "t" not in frame:
                raise ValueError(f"{agent}: no t column")
            out[str(agent)] = frame
        return out
    except (OSError, ValueError, KeyError, TypeError, AttributeError) as err:
        raise BaselineError(f"{path}: malformed reference trace ({err})") from None
