"""Neutral value types passed from the runner to the reports: what happened in each scenario."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

from kartci.verdict import CriterionResult, MetricVerdict, Status, worst

if TYPE_CHECKING:  # the report data's types; a verdict needs neither library
    import numpy as np
    import pandas as pd


@dataclass(frozen=True)
class Plots:
    """Time series and geometry a report draws; all read back from the run log."""

    kind: str  # "line" (a line lab) or "track" (a race track)
    course: np.ndarray  # (n, 2) line axis or track centreline, m
    edges: list[np.ndarray]  # track bounds (left, right), empty for a line
    tracks: dict[str, pd.DataFrame]  # agent -> t, x, y, offset, speed (+ line: progress)
    wheels: dict[str, pd.DataFrame]  # agent -> t, left, right (measured, rad/s)
    commands: dict[str, pd.DataFrame]  # agent -> t, left, right (commanded, rad/s)
    collisions: dict[str, pd.DataFrame]  # agent -> t, x, y, other, impulse_ns
    transient_s: float = 0.0  # start-up transient the metrics leave out
    obstacles: list[np.ndarray] = field(default_factory=list)  # (4, 2) box footprints, m
    horizons: dict[str, list[np.ndarray]] = field(default_factory=dict)  # agent -> MPCC plans
    solves: dict[str, pd.DataFrame] = field(default_factory=dict)  # agent -> t, solve_ms
    # agent -> t, x, y (localization estimate), error_m (APE translation against the truth)
    estimates: dict[str, pd.DataFrame] = field(default_factory=dict)
    # agent -> detected boxes at a few moments: (4, 2) footprint, m, and whether dynamic
    detections: dict[str, list[tuple[np.ndarray, bool]]] = field(default_factory=dict)
    # racing diagnostics (track kind): complete laps with their three sector times, the distance
    # from the nearest wheel to a track edge (negative: outside), the driver's commands
    laps: dict[str, pd.DataFrame] = field(default_factory=dict)  # agent -> lap, time_s, s1..s3
    track_length_m: float = 0.0
    margins: dict[str, pd.DataFrame] = field(default_factory=dict)  # agent -> t, margin_m
    controls: dict[str, pd.DataFrame] = field(default_factory=dict)  # agent -> t, named columns
    # the baseline's decimated reference trace (kartci.verdict.trace): agent -> t, x, y, speed...
    reference: dict[str, pd.DataFrame] = field(default_factory=dict)


@dataclass(frozen=True)
class ScenarioResult:
    """What became of one scenario: metric verdicts, criteria, gate problems and warnings, or the
    error that stopped it; run facts and what its plots draw."""

    name: str
    description: str
    verdicts: list[MetricVerdict] = field(default_factory=list)
    criteria: list[CriterionResult] = field(default_factory=list)
    error: str | None = None
    run: dict[str, Any] = field(default_factory=dict)  # sim_time_s, wall_s, rtf, log
    plots: Plots | None = None
    # the plots drawn as SVG for report-static.html, where the run was judged: in a worker with
    # -j N, so that drawing them overlaps other runs instead of following the last one
    static_figures: tuple[str, ...] | None = None
    # gate failures beyond metrics and criteria (strict mode: no baseline, a metric not in it)
    problems: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()  # worth a reader's attention, not a failure
    # those warnings a strict run fails on (a stale baseline, a loosened tolerance): see
    # runner.gate, which moves them to problems
    strict_warnings: tuple[str, ...] = ()

    @property
    def status(self) -> Status:
        """The worst of its verdicts, failed criteria and problems; ERROR when it has an error."""
        if self.error is not None:
            return Status.ERROR
        statuses = [v.status for v in self.verdicts]
        statuses += [Status.FAILED for c in self.criteria if not c.ok]
        statuses += [Status.FAILED for _ in self.problems]
        return worst(statuses)


def one_line(text: str, limit: int = 500) -> str:
    """User text for a one-line message: control characters and newlines become spaces."""
    flat = " ".join("".join(c if c.isprintable() else " " for c in text).split())
    return flat if len(flat) <= limit else flat[:limit - 1] + "…"


def exit_code(results: list[ScenarioResult]) -> int:
    """0 all pass, 1 a regression or a failed criterion, 2 a run error."""
    if any(r.status is Status.ERROR for r in results):
        return 2
    return 1 if any(r.status.bad for r in results) else 0


def overlay(base: Plots | None, head: Plots | None) -> Plots | None:
    """Both runs in one set of plots: every series keyed `base <agent>` / `head <agent>`, drawn
    on head's course (or base's when head has none)."""
    if base is None or head is None:
        return head or base

    def both(field_name: str) -> dict[str, pd.DataFrame]:
        return {f"{who} {agent}": frame for who, p in (("base", base), ("head", head))
                for agent, frame in getattr(p, field_name).items()}

    return replace(head, tracks=both("tracks"), wheels=both("wheels"),
                   commands=both("commands"), collisions=both("collisions"),
                   solves=both("solves"), horizons={}, laps=both("laps"), margins=both("margins"),
                   controls=both("controls"), reference={})
