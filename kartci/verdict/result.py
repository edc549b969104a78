"""The one result of a scenario (`ScenarioResult`, also public as `kartci.RunResult`): its
metrics, verdicts, criteria, problems or error, and what its figures draw; the exit code of a
set of them. Made by `kartci.verdict.judging` for the runner and the Python API alike, read by
the reports, the CLI, the API's callers and the pytest plugin."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kartci.core import Metric, RunFolder
from kartci.errors import did_you_mean
from kartci.verdict.baseline import CriterionResult, MetricVerdict, Status, worst
from kartci.verdict.criteria import CriterionChange

if TYPE_CHECKING:  # a result only carries its plots: judging needs neither pandas nor the figures
    from kartci.plotting import Plots
    from kartci.scenario.models import Scenario


@dataclass(frozen=True)
class ScenarioResult:
    """What became of one scenario: metric verdicts, criteria, gate problems and warnings, or the
    error that stopped it; run facts and what its plots draw.

    Attributes:
        name: The scenario's label (its name; `NAME@key=value` for a sweep point).
        verdicts: Each deterministic metric judged against the baseline (status `new` for a
            metric, or a scenario, without one, or with no comparable one).
        criteria: The scenario's pass criteria, each checked.
        run: The run record (run.json): sim_time_s, wall_s, messages, platform, log.
        warnings: Worth a reader's attention, not failures: a baseline made on another
            platform or from another scenario, a tolerance loosened beyond the policy, an
            ill-conditioned metric, a run in a process that is not pinned.
        scenario: The scenario as run (overrides applied); None when it was not judged.
        folder: The run's folder: `run.mcap`, `metrics.json`, `run.json`; `Path()` for a
            result made without one (an error before the run, a shard's summary).
        metrics: Every metric by name (`agent.name` when the scenario has several agents),
            each with its value (NaN where it cannot be computed) and unit; values are
            rounded to 10 significant digits, as stored and judged.
        baseline: The baseline file judged against; None when there is none or it was made
            from another scenario and not compared (the Python API).
    """

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
    # criteria added, removed or changed since the baseline was accepted (also in warnings;
    # a removed one in strict_warnings): the terminal table shows them as rows
    criteria_changes: tuple[CriterionChange, ...] = ()
    scenario: Scenario | None = None
    folder: Path = Path()
    metrics: Mapping[str, Metric] = field(default_factory=dict)
    baseline: Path | None = None

    @property
    def status(self) -> Status:
        """The worst of its verdicts, failed criteria and problems; ERROR when it has an error."""
        if self.error is not None:
            return Status.ERROR
        statuses = [v.status for v in self.verdicts]
        statuses += [Status.FAILED for c in self.criteria if not c.ok]
        statuses += [Status.FAILED for _ in self.problems]
        return worst(statuses)

    @property
    def passed(self) -> bool:
        """True unless a metric regressed or went missing, a criterion failed or the run
        failed (the CLI's exit code 0)."""
        return not self.status.bad

    @property
    def log(self) -> Path:
        """The run's MCAP log (opens in Foxglove, plays with `ros2 bag play`)."""
        return RunFolder(self.folder).log

    @property
    def sim_time_s(self) -> float:
        """Sim time the run reached, s (NaN when the run record does not say)."""
        return float(self.run.get("sim_time_s", math.nan))

    @property
    def wall_s(self) -> float:
        """Wall-clock time of the simulation, s (NaN when the run record does not say)."""
        return float(self.run.get("wall_s", math.nan))

    @property
    def messages(self) -> int:
        """Messages recorded in the log."""
        return int(self.run.get("messages", 0))

    @property
    def finished_course(self) -> bool:
        """True when every robot finished its course before the duration ran out."""
        return bool(self.run.get("finished_course", False))

    @property
    def replaced_agents(self) -> dict[str, str]:
        """Agents driven by an object handed to the Python API, by name, each with the object's
        class."""
        return dict(self.run.get("replaced_agents") or {})

    def value(self, name: str) -> float:
        """A metric's value by name (NaN where it cannot be computed).

        Raises:
            KeyError: No such metric in this run; the message lists those there are.
        """
        metric = self.metrics.get(name)
        if metric is None:
            raise KeyError(f"no metric '{name}' in run {self.name}"
                           f"{did_you_mean(name, self.metrics)}")
        return metric.value

    def table(self) -> str:
        """The verdicts and criteria as a plain-text table (what a failing test shows)."""
        rows = [("metric", "value", "baseline", "delta", "tolerance", "verdict")]
        for v in self.verdicts:
            d = v.delta
            rows.append((v.name, _num(v.value, v.unit), _num(v.baseline, v.unit),
                         "-" if d is None else f"{d:+.3g}",
                         "-" if v.tolerance is None else
                         f"±{v.tolerance:.3g} ({v.direction.value})", v.status.value))
        for c in self.criteria:
            rows.append((f"criterion {c.name}", _num(c.value, ""), c.bound, "", "",
                         "pass" if c.ok else "FAILED"))
        widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        lines = [f"scenario {self.name}: {self.status.value}"
                 + ("" if self.baseline else " (no baseline)")]
        lines += [f"error: {self.error}"] if self.error is not None else []
        lines += ["  ".join(cell.ljust(w) for cell, w in zip(r, widths, strict=True)).rstrip()
                  for r in rows]
        lines += [f"agent {a}: controller replaced by {cls}"
                  for a, cls in sorted(self.replaced_agents.items())]
        lines += [f"problem: {p}" for p in self.problems]
        lines += [f"warning: {w}" for w in self.warnings]
        lines.append(f"log: {self.log}")
        return "\n".join(lines)

    def __str__(self) -> str:
        """The verdict table."""
        return self.table()


def _num(x: float | None, unit: str) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    text = f"{x:.4g}"
    return f"{text} {unit}".strip() if unit and unit not in ("bool", "fraction") else text


RunResult = ScenarioResult  # the Python API's name for it (kartci.RunResult)


def exit_code(results: list[ScenarioResult]) -> int:
    """0 all pass, 1 a regression or a failed criterion, 2 a run error."""
    if any(r.status is Status.ERROR for r in results):
        return 2
    return 1 if any(r.status.bad for r in results) else 0
