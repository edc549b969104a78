"""Where jobs run: in this process, in a pool of processes, or as Ray tasks.

Each executor yields an Outcome per job as it finishes and reports what it knows as Events
(a job started, its sim time, its end). Every job writes only its own folder, and a
scenario + seed gives the same bytes in any process, so all executors give the same results.
"""

from __future__ import annotations

import multiprocessing as mp
import queue as queue_mod
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from kartci.runner.jobs import Context, Job, Outcome, run_job


class ExecutorKind(StrEnum):
    LOCAL = "local"  # this process with -j 1, a process pool with -j N
    RAY = "ray"  # one Ray task per job, local Ray or a cluster


class EventKind(StrEnum):
    STARTED = "started"
    PROGRESS = "progress"
    FINISHED = "finished"


@dataclass(frozen=True)
class Event:
    kind: EventKind
    folder: str  # the job's folder, relative to OUT
    sim_t: float = 0.0
    outcome: Outcome | None = None  # FINISHED only


Listener = Callable[[Event], None]


def serial(jobs: Sequence[Job], ctx: Context, emit: Listener) -> Iterator[Outcome]:
    for job in jobs:
        emit(Event(EventKind.STARTED, job.folder))
        yield run_job(job, ctx, lambda f, t: emit(Event(EventKind.PROGRESS, f, t)))


_QUEUE: Any = None  # the worker's end of the progress queue (set by _init_worker)


def _init_worker(q: Any) -> None:
    global _QUEUE
    _QUEUE = q


def _report(folder: str, t: float) -> None:
    _QUEUE.put((EventKind.PROGRESS, folder, t))


def _work(job: Job, ctx: Context) -> Outcome:
    _QUEUE.put((EventKind.STARTED, job.folder, 0.0))
    return run_job(job, ctx, _report)


def pool(jobs: Sequence[Job], ctx: Context, emit: Listener, workers: int) -> Iterator[Outcome]:
    """A spawn-context process pool: fresh interpreters, as a CLI run would be on any OS."""
    mpc = mp.get_context("spawn")
    events = mpc.Queue()

    def drain() -> None:
        while True:
            try:
                kind, folder, t = events.get_nowait()
            except queue_mod.Empty:
                return
            emit(Event(kind, folder, t))

    with ProcessPoolExecutor(max_workers=workers, mp_context=mpc, initializer=_init_worker,
                             initargs=(events,)) as ex:
        futures: dict[Future[Outcome], Job] = {ex.submit(_work, j, ctx): j for j in jobs}
        pending = set(futures)
        while pending:
            done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
            drain()
            for fut in done:
                yield _outcome(fut, futures[fut])
    drain()
    events.close()


def _outcome(fut: Future[Outcome], job: Job) -> Outcome:
    try:
        return fut.result()
    except Exception as err:  # the worker process died (e.g. a segfault in native code)
        return Outcome.failed(job, f"worker process failed: {type(err).__name__}: {err}")


def execute(jobs: Sequence[Job], ctx: Context, emit: Listener, workers: int = 1,
            kind: ExecutorKind = ExecutorKind.LOCAL,
            ray_address: str | None = None) -> Iterator[Outcome]:
    """Outcomes in the order jobs finish; FINISHED events are the caller's to emit."""
    if kind is ExecutorKind.RAY:
        from kartci.runner.ray_executor import ray_tasks

        return ray_tasks(jobs, ctx, emit, workers, ray_address)
    if workers <= 1 or len(jobs) <= 1:
        return serial(jobs, ctx, emit)
    return pool(jobs, ctx, emit, min(workers, len(jobs)))
