"""Accepting runs as baselines: the one workflow behind `kartci baseline update`,
`kartci.accept_baselines` and the pytest plugin's `--kartci-accept`; the only code that writes
baseline files (through `kartci.verdict.update`, atomically)."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kartci.core import RunFolder
from kartci.errors import SpecError
from kartci.plotting import Plots
from kartci.project import Project
from kartci.runner import conditioning
from kartci.runner.executors import execute
from kartci.runner.jobs import MAX_RUNS, Context, Job, check_count
from kartci.runner.outdir import check_inside, locked, read_manifest, valid_label
from kartci.runner.run import check_finished, recorded_scenario, reference_plots
from kartci.scenario.load import in_project
from kartci.scenario.models import Scenario
from kartci.verdict import (
    Change,
    Conditioning,
    MetricVerdict,
    criteria,
    fingerprint,
    ill_conditioned,
    load,
    read_json,
    update,
)
from kartci.verdict.baseline import above, judge, policy_bound, read_baseline
from kartci.verdict.judging import check_allowed
from kartci.verdict.trace import trace_path, write_trace

REPLICAS = 4  # the run itself and 3 with every robot's start moved 1-3 nm sideways
FIELD_MAX_CHARS = 80  # of one scenario field's value in the printed diff


@dataclass(frozen=True)
class FieldChange:
    """One scenario field the accepted baseline records differently, as JSON text (None: the
    field was not there before, or is not there now)."""

    field: str
    old: str | None
    new: str | None


@dataclass(frozen=True)
class Accepted:
    """What accepting one scenario's run wrote into its baseline file."""

    label: str
    path: Path  # the baseline file written
    changes: tuple[Change, ...]  # every metric: added, changed, removed or unchanged
    scenario_note: str | None  # the scenario hash first recorded, or a changed scenario accepted
    scenario_changes: tuple[FieldChange, ...]
    notes: tuple[str, ...]  # worst-conditioned metric, tolerances kept loose, reference trace
    warnings: tuple[str, ...]  # ill-conditioned metrics

    @property
    def changed(self) -> tuple[Change, ...]:
        """The metrics whose value was added, changed or removed."""
        return tuple(c for c in self.changes if c.kind != "unchanged")

    def lines(self) -> list[str]:
        """The report `kartci baseline update` prints for this scenario."""
        out = [] if self.scenario_note is None else [f"{self.label}: {self.scenario_note}"]
        out += [f"  scenario {f.field}: {_clip(f.old)} -> {_clip(f.new)}"
                for f in self.scenario_changes]
        out.append(f"{self.label}: {len(self.changed)} of {len(self.changes)} metrics changed")
        out += [f"  {c.kind:8s} {c.metric}: {round_trip_text(c.old)} -> {round_trip_text(c.new)}"
                for c in self.changed]
        return out + list(self.notes)


def round_trip_text(x: float | None) -> str:
    """A value as the shortest text that reads back as the same float: a change shows even
    where 4 significant digits would print "0.6612 -> 0.6612"."""
    return "—" if x is None else repr(float(x))


def _clip(text: str | None) -> str:
    if text is None:
        return "—"
    return text if len(text) <= FIELD_MAX_CHARS else text[:FIELD_MAX_CHARS - 1] + "…"


def accept(out: Path, project: Project, names: Sequence[str] = (), *,
           baselines: Path | None = None, replicas: int = REPLICAS, jobs: int = 1,
           say: Callable[[str], None] = lambda _line: None) -> list[Accepted]:
    """Store the runs in OUT as their scenarios' baselines, with each metric's spread over
    `replicas` conditioning replicas (those missing in OUT are run now, `jobs` at once; 0:
    record no spread), where they were made, the scenario they were made from and a decimated
    reference trace (baselines/traces/). Only complete, current, pinned runs are taken, and all
    are checked before anything is written: a scenario whose last run failed or did not finish
    is refused (SpecError), and nothing is replaced. `names`: the scenarios (default: those of
    the last run in OUT). `project`: its baselines (the default) and tolerance policy. `say`:
    progress lines (the replicas being run)."""
    if replicas == 1 or replicas < 0:
        raise SpecError(f"--replicas {replicas}: expected 0 (none) or 2 or more")
    if jobs < 1:
        raise SpecError(f"--jobs {jobs}: expected 1 or more")
    check_count("--replicas", replicas)
    check_count("--jobs", jobs)
    if not out.is_dir():
        raise SpecError(f"{out}: no such folder; run `kartci run` first")
    check_allowed(project)
    if baselines is None:
        target = project.writable(project.baselines, "--baselines DIR (in Python: baselines=)")
    else:
        target = baselines
    with locked(out):
        labels = list(names) or read_manifest(out)
        _check_labels(out, labels)
        if len(labels) * replicas > MAX_RUNS:  # each replica is a run of its own
            raise SpecError(f"{len(labels):,} scenarios x {replicas:,} replicas = "
                            f"{len(labels) * replicas:,} runs, more than the {MAX_RUNS:,} "
                            "allowed; split the command")
        folders = [RunFolder(out / label) for label in labels]
        checked = []
        for folder in folders:  # check everything before writing anything
            _check_acceptable(folder, replicas)
            load(target / f"{folder.name}.json")
            checked.append((folder, folder.read_metrics()))
        if replicas:
            _replicate(out, target, project, labels, replicas, jobs, say)
        # the traces' plots read the logs: after the cheap checks, still before any write
        traced = [(folder, values, reference_plots(folder), recorded_scenario(folder))
                  for folder, values in checked]
        return [_write(folder, target, project, values, drawn, scenario, bool(replicas))
                for folder, values, drawn, scenario in traced]


def _check_labels(out: Path, labels: list[str]) -> None:
    bad = [n for n in labels if not valid_label(n)]
    if bad:
        raise SpecError(f"{bad[0]}: not a scenario name (a folder directly in {out})")
    if not labels:
        raise SpecError(f"{out}: its last run had no scenarios")
    check_inside(out, labels)
    check_finished(out, labels)


def _check_acceptable(folder: RunFolder, replicas: int) -> None:
    """A complete, current run made with pinned kernels; with replicas, one the runner can
    repeat (agent objects handed to the Python API cannot leave their process)."""
    folder.check_complete()
    simd = conditioning.platform_of(folder).get("simd")
    if simd not in (None, "pinned"):  # a baseline holds every CPU's numbers
        raise SpecError(f"{folder.path}: run with {simd} SIMD kernels (KARTCI_SIMD=native or numpy "
                        "imported before kartci): its numbers are this CPU's only; run it again "
                        "with `kartci run`")
    replaced = _replaced(folder)
    if replicas and replaced:
        agents = ", ".join(f"{a}: {cls}" for a, cls in sorted(replaced.items()))
        raise SpecError(f"{folder.path}: driven by agent objects ({agents}), which conditioning "
                        "replicas cannot re-create; accept it with 0 replicas")


def _replaced(folder: RunFolder) -> dict[str, str]:
    replaced = folder.read_run_record().get("replaced_agents") or {}
    return {str(k): str(v) for k, v in replaced.items()}


def _write(folder: RunFolder, target: Path, proj: Project, values: dict[str, dict[str, Any]],
           drawn: Plots | None, scenario: Scenario, replicated: bool) -> Accepted:
    """One scenario's baseline written, and what that changed (criteria included)."""
    label, path = folder.name, target / f"{folder.name}.json"
    fields = fingerprint.fields(scenario, proj, _replaced(folder))
    spreads, provenance = _conditioning(folder) if replicated else (None, _provenance(folder))
    note, moved = _scenario_diff(path, fields)
    old = read_baseline(path)
    accepted = criteria.changes(None if old is None else old.doc, scenario.criteria)
    changes = update(path, label, values, spreads, provenance, fields, scenario.criteria)
    notes = [f"  accepted: {c.text().partition(':')[0]}" for c in accepted]
    more, warnings = _conditioning_notes(path)
    notes += more
    notes += _kept_loose(path, label, proj)
    if drawn is not None and drawn.tracks:
        size = write_trace(trace_path(target, label), drawn)
        notes.append(f"  reference trace {trace_path(target, label)} ({size} bytes)")
    return Accepted(label, path, tuple(changes), note, moved, tuple(notes), tuple(warnings))


def _provenance(folder: RunFolder) -> dict[str, Any]:
    platform = conditioning.platform_of(folder)
    return {"platform": platform} if platform else {}


def _conditioning(folder: RunFolder) -> tuple[dict[str, float | None] | None, dict[str, Any]]:
    measured = conditioning.spreads(folder)
    if measured is None:  # not a simulation (a scored real log): nothing to replicate
        return None, _provenance(folder)
    return measured, {**_provenance(folder), "conditioning": conditioning.record(folder)}


def _replicate(out: Path, target: Path, proj: Project, labels: list[str], replicas: int,
               workers: int, say: Callable[[str], None]) -> None:
    """Run the conditioning replicas OUT lacks, in `proj` (the scenario a log recorded carries
    no project); all must finish before anything is written."""
    todo = conditioning.missing_jobs(out, labels, replicas, lambda folder: Job(
        in_project(recorded_scenario(folder), proj), folder.name))
    if todo:
        say(f"running {len(todo)} conditioning replicas (start moved 1-{replicas - 1} nm) ...")
        for _ in execute(todo, Context(out, target, proj), lambda _event: None, workers):
            pass
    conditioning.check_complete(out, labels, replicas)


def _scenario_diff(path: Path, fields: dict[str, Any]) -> tuple[str | None,
                                                                 tuple[FieldChange, ...]]:
    """The scenario change an update accepts, field by field, read before it writes."""
    if not path.is_file():
        return None, ()
    try:
        found, old = fingerprint.recorded(read_json(path))
    except (OSError, ValueError, UnicodeDecodeError):  # load() checked it: cannot happen
        found, old = None, {}
    if found is None:
        return "scenario hash recorded (the baseline had none)", ()
    if found == fingerprint.digest(fields):
        return None, ()
    moved = fingerprint.changed(old, fields)
    note = f"accepting a changed scenario ({len(moved) or 'unrecorded'} fields)"

    def text(key: str, side: dict[str, Any]) -> str | None:
        return json.dumps(side[key]) if key in side else None

    return note, tuple(FieldChange(k, text(k, old), text(k, fields)) for k in moved)


def _conditioning_notes(path: Path) -> tuple[list[str], list[str]]:
    """The worst-conditioned metric of a baseline, and a warning for every ill-conditioned one."""
    entries = load(path) or {}
    verdicts = [judge(e.get("value"), str(e.get("unit", "")), name, e)
                for name, e in entries.items() if "spread" in e]
    if not verdicts:
        return [], []

    def ratio(v: MetricVerdict) -> float:
        declared = float(entries[v.name]["tolerance"])
        return math.inf if v.spread is None else (v.spread / declared if declared else (
            math.inf if v.spread else 0.0))

    worst = max(verdicts, key=ratio)
    tol = float(entries[worst.name]["tolerance"])
    size = "undefined in some replicas" if worst.spread is None else f"{worst.spread:.3g}"
    note = (f"  worst-conditioned: {worst.name}: spread {size}, tolerance {tol:.3g} "
            f"({worst.conditioning.value})")
    return [note], ill_conditioned([v for v in verdicts if v.conditioning is Conditioning.ILL])


def _kept_loose(path: Path, label: str, proj: Project) -> list[str]:
    """A line for every tolerance the update kept above the policy bound: never silent."""
    allowed = dict(proj.allow_loose_tolerances)
    out = []
    for name, entry in sorted((load(path) or {}).items()):
        bound = policy_bound(name, entry, proj.loosen_factor)
        if bound is None or not above(float(entry["tolerance"]), bound):
            continue
        reason = allowed.get(f"{label}:{name}")
        why = (f"allowed: {reason}" if reason else "not allowed: a strict run fails on it; "
               "narrow it, or allow it in [tool.kartci.allow_loose_tolerances]")
        out.append(f"  kept tolerance {name}: {float(entry['tolerance']):.3g} above the policy "
                   f"bound {bound:.3g} ({why})")
    return out
