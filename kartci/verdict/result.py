"""The one result of a scenario (`ScenarioResult`): its verdicts, criteria, problems or error,
and what its figures draw; the exit code of a set of them. Made by the runner, read by the
reports and the CLI."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from kartci.verdict.baseline import CriterionResult, MetricVerdict, Status, worst

if TYPE_CHECKING:  # a result only carries its plots: judging needs neither pandas nor the figures
    from kartci.figures import Plots


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
