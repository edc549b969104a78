"""`kartci baseline update`: the only command that writes baselines."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any

import typer

from kartci.cli.common import (
    BaselinesOpt,
    baseline_app,
    baselines_dir,
    err_console,
    out_console,
)
from kartci.errors import SpecError


def exact(x: float | None) -> str:
    """A value as the shortest text that reads back as the same float: a change shows even
    where 4 significant digits would print "0.6612 -> 0.6612"."""
    return "—" if x is None else repr(float(x))


@baseline_app.command("update")
def baseline_update(
    out: Annotated[Path, typer.Argument(help="A folder written by `kartci run`.")],
    names: Annotated[list[str] | None, typer.Argument(
        help="Scenarios (default: those of the last run in OUT).")] = None,
    baselines: BaselinesOpt = None,
    replicas: Annotated[int, typer.Option(
        help="Conditioning replicas per scenario: the run itself and K-1 with every robot's "
             "start moved k nm sideways (those missing in OUT are run now); each metric's "
             "spread over them goes into the baseline. 0: record no spread.")] = 4,
    jobs: Annotated[int, typer.Option("--jobs", "-j", help="Replicas run at once.")] = 1,
) -> None:
    """Store a run's metrics as the baselines, with each metric's spread over conditioning
    replicas, where they were made, and a decimated reference trace of its paths
    (baselines/traces/, for the report's overlay); the only command that writes baselines. Only a
    complete, current, pinned run is taken: a scenario whose last run failed or did not finish
    is refused, and with no names only the scenarios of the last run in OUT are taken. A metric
    whose spread exceeds its tolerance is flagged ill-conditioned."""
    from kartci.core import RunFolder
    from kartci.runner.outdir import check_inside, locked, read_manifest, valid_label
    from kartci.runner.run import check_complete, check_finished, reference_plots
    from kartci.verdict import load, update
    from kartci.verdict.trace import trace_path, write_trace

    _check_options(replicas, jobs)

    if not out.is_dir():
        raise SpecError(f"{out}: no such folder; run `kartci run` first")
    target = baselines_dir(baselines, must_exist=False)
    with locked(out):
        labels = names or read_manifest(out)
        bad = [n for n in labels if not valid_label(n)]
        if bad:
            raise SpecError(f"{bad[0]}: not a scenario name (a folder directly in {out})")
        if not labels:
            raise SpecError(f"{out}: its last run had no scenarios")
        check_inside(out, labels)
        check_finished(out, labels)
        checked = []
        for label in labels:  # check everything before writing anything
            folder = out / label
            check_complete(folder)
            _check_pinned(folder)
            load(target / f"{label}.json")
            checked.append((label, RunFolder(folder).read_metrics()))
        if replicas:
            _replicate(out, target, labels, replicas, jobs)
        # the traces' plots read the logs: after the cheap checks, still before any write
        traced = [(label, values, reference_plots(out / label), _fields(out / label))
                  for label, values in checked]
        for label, values, drawn, fields in traced:
            spreads, made = _conditioning(out / label) if replicas else (None, _made(out / label))
            _print_scenario_diff(target / f"{label}.json", label, fields)
            changes = update(target / f"{label}.json", label, values, spreads, made, fields)
            moved = [c for c in changes if c.kind != "unchanged"]
            out_console.print(f"{label}: {len(moved)} of {len(changes)} metrics changed",
                              highlight=False, markup=False)
            for c in moved:
                out_console.print(f"  {c.kind:8s} {c.metric}: {exact(c.old)} -> {exact(c.new)}",
                                  highlight=False, markup=False)
            _print_conditioning(target / f"{label}.json")
            _print_kept_loose(target / f"{label}.json", label)
            if drawn is not None and drawn.tracks:
                size = write_trace(trace_path(target, label), drawn)
                out_console.print(f"  reference trace {trace_path(target, label)} ({size} bytes)",
                                  highlight=False, markup=False)


def _check_options(replicas: int, jobs: int) -> None:
    if replicas == 1 or replicas < 0:
        raise SpecError(f"--replicas {replicas}: expected 0 (none) or 2 or more")
    if jobs < 1:
        raise SpecError(f"--jobs {jobs}: expected 1 or more")


def _check_pinned(folder: Path) -> None:
    """A baseline holds every CPU's numbers: a run with the CPU's own kernels is refused."""
    from kartci.runner.conditioning import platform_of

    simd = platform_of(folder).get("simd")
    if simd not in (None, "pinned"):
        raise SpecError(f"{folder}: run with {simd} SIMD kernels (KARTCI_SIMD=native or numpy "
                        "imported before kartci): its numbers are this CPU's only; run it again "
                        "with `kartci run`")


def _made(folder: Path) -> dict[str, Any]:
    from kartci.runner.conditioning import platform_of

    platform = platform_of(folder)
    return {"platform": platform} if platform else {}


def _conditioning(folder: Path) -> tuple[dict[str, float | None] | None, dict[str, Any]]:
    from kartci.runner.conditioning import record, spreads

    measured = spreads(folder)
    if measured is None:  # not a simulation (a scored real log): nothing to replicate
        return None, _made(folder)
    return measured, {**_made(folder), "conditioning": record(folder)}


def _replicate(out: Path, target: Path, labels: list[str], replicas: int, workers: int) -> None:
    """Run the conditioning replicas OUT lacks; all must finish before anything is written."""
    from kartci.runner.conditioning import check_complete, missing_jobs
    from kartci.runner.executors import execute
    from kartci.runner.jobs import Context, Job
    from kartci.runner.run import recorded_scenario

    todo = missing_jobs(out, labels, replicas,
                        lambda folder: Job(recorded_scenario(folder), folder.name))
    if todo:
        err_console.print(f"running {len(todo)} conditioning replicas (start moved 1-"
                          f"{replicas - 1} nm) ...", highlight=False, markup=False)
        for _ in execute(todo, Context(out, target), lambda _event: None, workers):
            pass
    check_complete(out, labels, replicas)


def _print_conditioning(path: Path) -> None:
    """The worst-conditioned metric of a baseline, and every ill-conditioned one."""
    from kartci.verdict import Conditioning, ill_conditioned, load
    from kartci.verdict.baseline import judge

    entries = load(path) or {}
    verdicts = [judge(e.get("value"), str(e.get("unit", "")), name, e)
                for name, e in entries.items() if "spread" in e]
    if not verdicts:
        return
    def ratio(v: Any) -> float:
        declared = float(entries[v.name]["tolerance"])
        return math.inf if v.spread is None else (v.spread / declared if declared else (
            math.inf if v.spread else 0.0))
    worst = max(verdicts, key=ratio)
    tol = float(entries[worst.name]["tolerance"])
    size = "undefined in some replicas" if worst.spread is None else f"{worst.spread:.3g}"
    out_console.print(f"  worst-conditioned: {worst.name}: spread {size}, tolerance {tol:.3g} "
                      f"({worst.conditioning.value})", highlight=False, markup=False)
    for line in ill_conditioned([v for v in verdicts if v.conditioning is Conditioning.ILL]):
        err_console.print(f"kartci: warning: {path.stem}: {line}", highlight=False,
                          markup=False)


def _fields(folder: Path) -> dict[str, Any]:
    """The resolved scenario a run folder's log recorded, as a baseline stores it."""
    from kartci.runner.run import recorded_scenario
    from kartci.verdict import fingerprint

    return fingerprint.fields(recorded_scenario(folder))


def _print_scenario_diff(path: Path, label: str, fields: dict[str, Any]) -> None:
    """The scenario change this update accepts, field by field (old -> new), before it writes."""
    import json

    from kartci.verdict import fingerprint, read_json

    if not path.is_file():
        return
    try:
        found, old = fingerprint.recorded(read_json(path))
    except (OSError, ValueError, UnicodeDecodeError):  # load() checked it: cannot happen
        found, old = None, {}
    if found is None:
        out_console.print(f"{label}: scenario hash recorded (the baseline had none)",
                          highlight=False, markup=False)
        return
    if found == fingerprint.digest(fields):
        return
    moved = fingerprint.changed(old, fields)
    out_console.print(f"{label}: accepting a changed scenario ({len(moved) or 'unrecorded'} "
                      "fields)", highlight=False, markup=False)

    def text(key: str, side: dict[str, Any]) -> str:
        shown = json.dumps(side[key]) if key in side else "—"
        return shown if len(shown) <= 80 else shown[:79] + "…"

    for key in moved:
        out_console.print(f"  scenario {key}: {text(key, old)} -> {text(key, fields)}",
                          highlight=False, markup=False)


def _print_kept_loose(path: Path, label: str) -> None:
    """A line for every tolerance the update kept above the policy bound: never silent."""
    from kartci import project
    from kartci.verdict import load
    from kartci.verdict.baseline import above, policy_bound

    proj = project.current()
    allowed = dict(proj.allow_loose_tolerances)
    for name, entry in sorted((load(path) or {}).items()):
        bound = policy_bound(name, entry, proj.loosen_factor)
        if bound is None or not above(float(entry["tolerance"]), bound):
            continue
        reason = allowed.get(f"{label}:{name}")
        why = (f"allowed: {reason}" if reason else "not allowed: a strict run fails on it; "
               "narrow it, or allow it in [tool.kartci.allow_loose_tolerances]")
        out_console.print(f"  kept tolerance {name}: {float(entry['tolerance']):.3g} above the "
                          f"policy bound {bound:.3g} ({why})", highlight=False, markup=False)
