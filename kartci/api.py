"""kartci's Python API: load a scenario, run it, judge it, read the result.

```python
import kartci

result = kartci.run("line_straight", overrides=["duration_s=10",
                                                "metrics.line_tracking.transient_s=2"])
assert result.value("cross_track_max_m") < 0.002
print(result.table())
```

`kartci.run` does what `kartci run NAME` does for one scenario (simulate, record the log, score
it, judge it against the baseline and the scenario's criteria) and returns a `RunResult`
instead of writing reports and an exit code. Agents may be handed in as objects
(`agents={"kart0": MyController()}`) for a test of your own controller; see `kartci.Agent`.
For a run you step yourself, see `kartci.Session`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from kartci.core.runfolder import RunFolder

if TYPE_CHECKING:
    from kartci.core import Metric
    from kartci.scenario.models import Scenario
    from kartci.verdict import CriterionResult, MetricVerdict, Status


def load_scenario(scenario: str | Path, overrides: Sequence[str] = (), *,
                  allow_outside_paths: bool = False) -> Scenario:
    """Load and validate a scenario file.

    Args:
        scenario: A name on the project's scenario path (`"line_straight"`), or the path of a
            YAML file (a `Path`, or a string ending in `.yaml` or holding a `/`).
        overrides: `dotted.key=value` assignments, as `kartci run --set` takes them
            (`"duration_s=3"`, `"agents.lt0.controller.kp=80"`); values are parsed as YAML.
        allow_outside_paths: Let track, world and model files lie outside the project and
            kartci's data (absolute paths, `..`, symlinks), as `--allow-outside-paths`.

    Returns:
        The validated, frozen scenario, with world and robot files resolved.

    Raises:
        SpecError: The file is missing or malformed, or a value is bad; the message names the
            file, the key and what was expected.
    """
    from kartci.scenario.load import load_scenario as load

    return load(scenario, list(overrides), allow_outside_paths=allow_outside_paths)


@dataclass(frozen=True)
class RunResult:
    """One run of one scenario: its metrics, their verdicts and where its log is.

    Attributes:
        scenario: The scenario as run (overrides applied).
        folder: The run's folder: `run.mcap`, `metrics.json`, `run.json`.
        metrics: Every metric by name (`agent.name` when the scenario has several agents),
            each with its value (NaN where it cannot be computed) and unit; values are
            rounded to 10 significant digits, as stored and judged.
        verdicts: Each deterministic metric judged against the baseline (status `new` for a
            metric, or a scenario, without one).
        criteria: The scenario's pass criteria, each checked.
        baseline: The baseline file judged against; None when the scenario has none.
        sim_time_s: Sim time the run reached, s.
        wall_s: Wall-clock time of the simulation and scoring, s.
        messages: Messages recorded in the log.
        finished_course: True when every robot finished its course before the duration ran out.
        replaced_agents: Agents driven by an object handed in, by name: the object's class.
        warnings: Worth a reader's attention, not failures: a baseline made on another
            platform or from another scenario (stale), a tolerance loosened beyond the policy,
            an ill-conditioned metric, a run in a process that is not pinned.
    """

    scenario: Scenario
    folder: Path
    metrics: Mapping[str, Metric]
    verdicts: tuple[MetricVerdict, ...]
    criteria: tuple[CriterionResult, ...]
    baseline: Path | None
    sim_time_s: float
    wall_s: float
    messages: int
    finished_course: bool
    replaced_agents: Mapping[str, str] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    @property
    def name(self) -> str:
        """The scenario's name."""
        return self.scenario.name

    @property
    def log(self) -> Path:
        """The run's MCAP log (opens in Foxglove, plays with `ros2 bag play`)."""
        return RunFolder(self.folder).log

    @property
    def status(self) -> Status:
        """The worst of the verdicts and criteria (`failed` for an unmet criterion)."""
        from kartci.verdict import Status, worst

        statuses = [v.status for v in self.verdicts]
        statuses += [Status.FAILED for c in self.criteria if not c.ok]
        return worst(statuses)

    @property
    def passed(self) -> bool:
        """True unless a metric regressed or went missing or a criterion failed (the CLI's
        exit code 0)."""
        return not self.status.bad

    def value(self, name: str) -> float:
        """A metric's value by name (NaN where it cannot be computed).

        Raises:
            KeyError: No such metric in this run; the message lists those there are.
        """
        metric = self.metrics.get(name)
        if metric is None:
            from kartci.project import did_you_mean

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
        lines += ["  ".join(cell.ljust(w) for cell, w in zip(r, widths, strict=True)).rstrip()
                  for r in rows]
        lines += [f"agent {a}: controller replaced by {cls}"
                  for a, cls in sorted(self.replaced_agents.items())]
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


def run(scenario: str | Path | Scenario, *, overrides: Sequence[str] = (),
        out: str | Path | None = None, agents: Mapping[str, object] | None = None,
        baselines: str | Path | None = None, allow_outside_paths: bool = False) -> RunResult:
    """Run one scenario, record its log, score it and judge it against its baseline.

    Args:
        scenario: A scenario name or YAML path (see `load_scenario`), or a `Scenario`.
        overrides: `dotted.key=value` assignments applied before the run (`--set`).
        out: Output folder; the run goes into `OUT/<scenario>/` as with `kartci run --out`
            (an earlier run there is replaced). Default: a new temporary folder, kept (its
            path is in the result).
        agents: Objects replacing the scenario's controllers, by agent name; each must
            satisfy `kartci.Agent` (period_s, inputs, on_message, step). The log records the
            scenario as written plus which agents were replaced, and by what.
        baselines: Folder of baseline files. Default: the project's (`[tool.kartci]
            baselines`).
        allow_outside_paths: As for `load_scenario`.

    Returns:
        The run's metrics, verdicts and criteria (`result.passed`, `result.table()`).

    Raises:
        SpecError: Bad input (the scenario, an override, an agent object, criteria on
            unknown metrics, a run shorter than its metrics' transient).
        RunError: The simulation broke (a non-finite state).
        KartciError: Any other problem kartci reports; an exception raised by an agent object
            (your controller) propagates unchanged.
    """
    import tempfile
    import time

    from kartci import portable, project
    from kartci.runner.run import check_criteria_names, run_pinned, trusted
    from kartci.scenario.load import with_overrides
    from kartci.scenario.models import Scenario
    from kartci.verdict import (
        check_criteria,
        compare,
        ill_conditioned,
        load,
        made_where,
        read_json,
    )

    if isinstance(scenario, Scenario):
        spec = with_overrides(scenario, list(overrides), allow_outside_paths=allow_outside_paths)
    else:
        spec = load_scenario(scenario, overrides, allow_outside_paths=allow_outside_paths)
    check_criteria_names([spec])
    root = Path(out) if out is not None else Path(tempfile.mkdtemp(prefix=f"kartci-{spec.name}-"))
    folder = root / spec.name
    t0 = time.perf_counter()
    facts = run_pinned(spec, root, folder, agents)
    wall = time.perf_counter() - t0
    doc = read_json(RunFolder(folder).metrics)
    values = RunFolder(folder).read_metrics()
    base_dir = Path(baselines) if baselines is not None else project.current().baselines
    base_file = base_dir / f"{spec.name}.json"
    baseline = load(base_file)
    verdicts, doubts, _ = trusted(compare(values, baseline), baseline, spec, base_file)
    crit = check_criteria(values, spec.criteria)
    note = portable.mismatch(made_where(base_file).get("platform"), facts.get("platform", {}))
    unpinned = facts.get("platform", {}).get("simd") == portable.Pin.UNPINNED.value
    warnings = ([note] if note else []) + ill_conditioned(verdicts) + (
        ["this Python process was not started pinned (numpy or the process came before "
         "`import kartci`) and agent objects run here: last bits may differ from `kartci run`; "
         "see kartci.portable"] if unpinned else []) + doubts
    return RunResult(
        scenario=spec, folder=folder,
        metrics={name: _metric(name, m)
                 for part in ("metrics", "timing") for name, m in doc.get(part, {}).items()},
        verdicts=tuple(verdicts), criteria=tuple(crit),
        baseline=base_file if base_file.exists() else None,
        sim_time_s=float(facts["sim_time_s"]), wall_s=wall, messages=int(facts["messages"]),
        finished_course=bool(facts["finished_course"]),
        replaced_agents=dict(facts.get("replaced_agents", {})), warnings=tuple(warnings))


def _metric(name: str, entry: dict[str, Any]) -> Metric:
    from kartci.core import Metric

    value = entry.get("value")
    extra = {k: v for k, v in entry.items() if k not in ("value", "unit")}
    return Metric(name, math.nan if value is None else float(value), str(entry.get("unit", "")),
                  extra)


__all__ = ["RunResult", "load_scenario", "run"]
