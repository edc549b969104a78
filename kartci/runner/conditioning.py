"""Conditioning: how far each metric moves when every robot starts a few nanometres elsewhere.

A metric whose spread over such replicas (`Vary.START`) is comparable to its tolerance is
chaotic there: a last-bit difference between two CPUs, or any unrelated change, flips its
verdict. `kartci run --conditioning K` measures the spread and judges with it;
`kartci baseline update` records it in the baseline, where every later run is judged with it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

from kartci.bridge.lockstep import ARRIVALS
from kartci.core import RunFolder
from kartci.errors import BaselineError
from kartci.runner.jobs import REPEAT_PREFIX, START_STEP_M, Job, Vary, replica
from kartci.verdict import (
    SPREAD_MULTIPLE,
    Conditioning,
    MetricVerdict,
    compare,
    ill_conditioned,
    load,
    spread,
)
from kartci.verdict.baseline import conditioning, definition, read_json
from kartci.verdict.result import ScenarioResult

DEFAULT_REPLICAS = 4  # the run itself and 3 nudged: enough to see a bifurcation, 4x the cost


def _run_fact(folder: RunFolder, key: str) -> dict[str, Any]:
    try:
        run = read_json(folder.run_record)
    except (OSError, ValueError):
        return {}
    found = run.get(key) if isinstance(run, dict) else None
    return found if isinstance(found, dict) else {}


def _variation(folder: RunFolder) -> dict[str, Any]:
    return _run_fact(folder, "variation")


def platform_of(folder: RunFolder) -> dict[str, Any]:
    """Where a run folder's numbers were made (run.json), or {} when it does not say."""
    return _run_fact(folder, "platform")


def replica_folders(folder: RunFolder) -> list[RunFolder]:
    """The complete start replicas of a scenario folder."""
    out = []
    for path in sorted(folder.path.glob(f"{REPEAT_PREFIX}*")):
        rep = RunFolder(path)
        if rep.metrics.is_file() and not rep.error.exists() and (
                _variation(rep).get("vary") == Vary.START.value):
            out.append(rep)
    return out


def spreads(folder: RunFolder) -> dict[str, float | None] | None:
    """Each metric's range over the judged run and its start replicas; None without replicas."""
    reps = replica_folders(folder)
    if not reps:
        return None
    samples = [f.read_metrics() for f in [folder, *reps]]
    names = sorted(set().union(*samples))

    def value(sample: dict[str, dict[str, Any]], name: str) -> float | None:
        v = sample.get(name, {}).get("value")
        return None if v is None else float(v)

    return {n: spread([value(s, n) for s in samples]) for n in names}


def record(folder: RunFolder) -> dict[str, Any]:
    """How the spreads of `folder` were measured, for the baseline file."""
    return {"replicas": len(replica_folders(folder)) + 1, "vary": Vary.START.value,
            "step_m": START_STEP_M, "tolerance_at_least": f"{SPREAD_MULTIPLE:g} x spread"}


def stack_repeats(folder: RunFolder) -> bool:
    """Whether the replicas of `folder` repeat it unchanged (an external stack's scenario)."""
    return any(_variation(rep).get("step") == 0.0 for rep in replica_folders(folder))


def divergence(folder: RunFolder, varied: list[str]) -> str:
    """Why repeats of an external stack's run differ: the first differing message between the
    run and the first repeat whose metrics differ, and the first tick at which the stack's
    messages arrived in another order."""
    from kartci.logs.diff import DiffOptions, diff_logs  # the log reader, only when needed

    mine = folder.read_metrics()
    other = next((r for r in replica_folders(folder)
                  if any(r.read_metrics().get(n) != mine.get(n) for n in varied)), None)
    if other is None:
        return ""
    where = []
    first = diff_logs(folder.log, other.log, DiffOptions()).first
    if first is not None:
        where.append(f"first difference against {other.name}: {first.topic} message "
                     f"{first.index} at t = {first.t_ns * 1e-9:.3f} s")
    for mine_log in sorted(folder.path.glob(f"*.{ARRIVALS}")):
        theirs = other.path / mine_log.name
        if not theirs.is_file():
            continue
        for a, b in zip(mine_log.read_text().splitlines(), theirs.read_text().splitlines(),
                        strict=False):
            if a != b:
                t, *order_a = a.split()
                order_b = b.split()[1:]
                at = next((i for i, (x, y) in enumerate(zip(order_a, order_b, strict=False))
                           if x != y), min(len(order_a), len(order_b)))
                topic = (order_a + order_b)[min(at, len(order_a + order_b) - 1)] if (
                    order_a or order_b) else "?"
                where.append(f"the stack's messages first arrived in another order at t = "
                             f"{int(t) * 1e-9:.3f} s ({topic}: {' '.join(order_a)} | "
                             f"{' '.join(order_b)})")
                break
    return "; ".join(where)


def stack_warnings(verdicts: list[MetricVerdict], folder: RunFolder) -> list[str]:
    """One line for the metrics that differ between repeats of an external stack's run."""
    varied = [v.name for v in verdicts if v.conditioning is Conditioning.ILL]
    if not varied:
        return []
    why = divergence(folder, varied)
    return [f"{', '.join(varied)} differ between repeats of the same run: the external stack "
            f"does not answer deterministically{'; ' + why if why else ''} "
            "(docs/explain/lockstep.md says what the lockstep cannot order)"]


def judged(result: ScenarioResult, folder: RunFolder, baselines: Path) -> ScenarioResult:
    """A result judged again with the spreads its own replicas measured (a --conditioning run);
    unchanged without replicas or with an error."""
    measured = spreads(folder) if result.error is None else None
    if measured is None:
        return result
    base = load(baselines / f"{result.name}.json")
    entries = None if base is None else {
        name: {**entry, "spread": measured.get(name)} for name, entry in base.items()}
    verdicts = compare(folder.read_metrics(), entries)
    verdicts = [v if v.baseline is not None or v.name not in measured else
                _unjudged(v, measured[v.name]) for v in verdicts]
    exact = stack_repeats(folder)
    if exact:  # the same run repeated: any spread is the stack's nondeterminism
        verdicts = [replace(v, conditioning=Conditioning.ILL if v.spread is None or v.spread > 0
                            else Conditioning.WELL) if v.name in measured else v
                    for v in verdicts]
    policed = {v.name: v for v in result.verdicts}  # the policy is the stored file's
    verdicts = [replace(v, policy=policed[v.name].policy, policy_bound=policed[v.name]
                        .policy_bound) if v.name in policed else v for v in verdicts]
    old = [w for w in result.warnings if " is ill-conditioned " not in w]
    found = stack_warnings(verdicts, folder) if exact else ill_conditioned(verdicts)
    return replace(result, verdicts=verdicts, warnings=(*old, *found))


def _unjudged(v: MetricVerdict, sp: float | None) -> MetricVerdict:
    """A metric with no baseline yet: its spread against the tolerance it would get."""
    d = definition(v.name.rsplit(".", 1)[-1])
    if d is None or v.value is None:
        return replace(v, spread=sp)
    return replace(v, spread=sp, conditioning=conditioning(sp, d.default_tolerance(v.value)))


def missing_jobs(out: Path, labels: list[str], replicas: int,
                 recorded: Callable[[RunFolder], Job]) -> list[Job]:
    """The start replicas still to run so that each label has `replicas` samples."""
    jobs = []
    for label in simulated(out, labels):
        folder = RunFolder(out / label)
        have = {int(p.name.removeprefix(REPEAT_PREFIX)) for p in replica_folders(folder)
                if p.name.removeprefix(REPEAT_PREFIX).isdigit()}
        need = [k for k in range(1, replicas) if k not in have]
        if need:
            job = recorded(folder)
            jobs += [Job(replica(job.spec, Vary.START, k), label, k, Vary.START) for k in need]
    return jobs


def simulated(out: Path, labels: list[str]) -> list[str]:
    """The labels whose folders kartci simulated (an imported or scored real log has nothing
    to replicate: its spread is not measured)."""
    return [label for label in labels if platform_of(RunFolder(out / label))]


def check_complete(out: Path, labels: list[str], replicas: int) -> None:
    """Every simulated label has its replicas (after running them): else nothing is written."""
    for label in simulated(out, labels):
        n = len(replica_folders(RunFolder(out / label))) + 1
        if n < replicas:
            raise BaselineError(f"{label}: {n} of {replicas} conditioning replicas finished; "
                                "nothing written (see the replicas' error.json)")

