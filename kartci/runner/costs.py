"""How long each scenario took last time, so that `-j N` starts the longest first.

A suite's wall time with several workers is set by its tail: a long run started last keeps one
core busy alone at the end. Simulated duration misjudges cost (18 s of a lidar scenario with
two MPCC karts costs more than 42 s of a line tracker), so the runner remembers each label's
wall time in the cache folder and orders by it, longest first. A label it has not seen is
estimated from its simulated duration at the median real-time factor of those it has.
Times are kept per label and scenario content (a `--set duration_s=2` run of a scenario
teaches nothing about the full one). Only the order changes: every job writes its own folder,
so results are the same in any order.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import statistics
from collections.abc import Iterable, Sequence
from pathlib import Path

from kartci.atomic import write_text_atomic
from kartci.boundedio import JSON_MAX_BYTES, read_bytes
from kartci.cachedir import cache_dir
from kartci.runner.jobs import Job, Outcome

KEEP = 500  # entries kept, the most recently run
FILE = "timings.json"  # {key: {"wall_s": job wall time, "sim_s": scenario duration}}


def _path() -> Path:
    return cache_dir() / FILE


def key(job: Job) -> str:
    """`<label>#<hash of the validated scenario>`: the same label with other settings is
    another run."""
    digest = hashlib.sha256(job.spec.model_dump_json().encode()).hexdigest()[:12]
    return f"{job.label}#{digest}"


def load() -> dict[str, tuple[float, float]]:
    """key -> (wall s, sim s) of its last run; empty when the file is missing or unreadable
    (a cache is never worth a failed run)."""
    try:
        raw = json.loads(read_bytes(_path(), JSON_MAX_BYTES))
        return {str(k): (float(v["wall_s"]), float(v["sim_s"])) for k, v in raw.items()
                if float(v["wall_s"]) > 0 and float(v["sim_s"]) > 0}
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return {}


def estimate_s(job: Job, known: dict[str, tuple[float, float]]) -> float:
    """The job's expected wall time, s: its last run's, else its sim time at the median
    real-time factor of the known runs (at 1x when none is known)."""
    if key(job) in known:
        return known[key(job)][0]
    rtf = statistics.median(s / w for w, s in known.values()) if known else 1.0
    return job.spec.duration_s / rtf


def order(jobs: Sequence[Job]) -> list[Job]:
    """Longest expected wall time first (ties: the given order)."""
    known = load()
    return sorted(jobs, key=lambda j: -estimate_s(j, known))


def remember(outcomes: Iterable[Outcome]) -> None:
    """Merge this run's wall times into the cache file; the judged run (repeat 0) of each label
    that finished. Write errors are ignored: a read-only cache only loses the ordering."""
    fresh = {key(o.job): {"wall_s": o.job_s, "sim_s": o.job.spec.duration_s}
             for o in outcomes if o.job.repeat == 0 and o.error is None and o.job_s > 0}
    if not fresh:
        return
    old = {k: {"wall_s": w, "sim_s": s} for k, (w, s) in load().items() if k not in fresh}
    table = list({**old, **fresh}.items())[-KEEP:]  # oldest first: a scenario edited away ages out
    with contextlib.suppress(OSError):
        write_text_atomic(_path(), json.dumps(dict(table), indent=1) + "\n")
