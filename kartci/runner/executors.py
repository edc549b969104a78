"""Where jobs run: in this process, in a pool of processes, or as Ray tasks.

Each executor yields an Outcome per job as it finishes and reports what it knows as Events
(a job started, its sim time, its end). Every job writes only its own folder, and a
scenario + seed gives the same bytes in any process, so all executors give the same results.
"""

from __future__ import annotations

import ctypes
import multiprocessing as mp
import os
import queue as queue_mod
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from kartci import portable
from kartci.portable import Pin
from kartci.runner.events import Event, EventKind, Listener, lost
from kartci.runner.jobs import Context, Job, Outcome, run_job
from kartci.runner.kinds import ExecutorKind
from kartci.runner.pinned import call_pinned
from kartci.runner.ray_executor import ray_tasks

_PR_SET_PDEATHSIG = 1  # linux/prctl.h


def serial(jobs: Sequence[Job], ctx: Context, emit: Listener) -> Iterator[Outcome]:
    """Run the jobs one after another in this process."""
    for job in jobs:
        yield _here(job, ctx, emit)


def _here(job: Job, ctx: Context, emit: Listener,
          tick: Callable[[], None] | None = None) -> Outcome:
    """Run a job in this process; `tick` is called with every progress report."""
    def progress(folder: str, t: float) -> None:
        emit(Event(EventKind.PROGRESS, folder, t))
        if tick is not None:
            tick()

    emit(Event(EventKind.STARTED, job.folder))
    outcome = run_job(job, ctx, progress)
    emit(Event(EventKind.FINISHED, job.folder, outcome=outcome))
    return outcome


_QUEUE: Any = None  # the worker's end of the progress queue (set by _init_worker)


def _init_worker(q: Any, parent: int) -> None:
    global _QUEUE
    _QUEUE = q
    die_with_parent(parent)


def die_with_parent(parent: int) -> None:
    """A worker must not outlive the command that started it: orphaned, it would keep writing
    into OUT and then block for ever on the progress pipe. On Linux the kernel kills it when
    its parent dies (prctl PR_SET_PDEATHSIG); everywhere, a daemon thread checks once a second
    that the parent is still its parent (which also covers a parent that died before prctl)."""
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass  # the thread below still applies

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="kartci-parent-watch", daemon=True).start()


def _report(folder: str, t: float) -> None:
    _QUEUE.put((EventKind.PROGRESS, folder, t))


def _work(job: Job, ctx: Context) -> Outcome:
    _QUEUE.put((EventKind.STARTED, job.folder, 0.0))
    return run_job(job, ctx, _report)


class _Workers:
    """Spawned worker processes (fresh interpreters, as on any OS), each given one run at a
    time so that no run waits behind a busy worker while another is free. A dispatcher thread
    hands out runs the moment a worker is free: this process's own run (and its scoring and
    drawing) reports progress only now and then, and a worker must not idle until it does."""

    def __init__(self, ctx: Context, emit: Listener, n: int, todo: deque[Job]) -> None:
        self.ctx, self.emit, self.slots, self.todo = ctx, emit, n, todo
        mpc = mp.get_context("spawn")
        self.events = mpc.Queue()
        self.ex = ProcessPoolExecutor(max_workers=n, mp_context=mpc, initializer=_init_worker,
                                      initargs=(self.events, os.getpid()))
        self.lock = threading.Lock()  # guards todo, running and slots
        self.running: dict[Future[Outcome], Job] = {}
        self.finished: deque[Outcome] = deque()
        self.closed = threading.Event()
        self.dispatcher = threading.Thread(target=self._dispatch, name="kartci-dispatch",
                                           daemon=True)
        self.dispatcher.start()

    def take(self) -> Job | None:
        """The next run for this process, if any is left."""
        with self.lock:
            return self.todo.popleft() if self.todo else None

    def busy(self) -> bool:
        """Runs are still out with the workers (or finished and not yet collected)."""
        with self.lock:
            return bool(self.running or self.finished)

    def _dispatch(self) -> None:
        while not self.closed.is_set():
            with self.lock:
                while self.todo and len(self.running) < self.slots:
                    try:
                        self.running[self.ex.submit(_work, self.todo[0], self.ctx)] = self.todo[0]
                    except (BrokenProcessPool, RuntimeError):  # no workers: this process does
                        self.slots = 0  # the rest
                        break
                    self.todo.popleft()
                pending = [f for f in self.running if not f.done()]
            if pending:
                wait(pending, timeout=0.1, return_when=FIRST_COMPLETED)
            else:
                self.closed.wait(0.05)

    def tick(self) -> None:
        """Relay the workers' events and collect finished runs (in the calling thread)."""
        while True:
            try:
                kind, folder, t = self.events.get_nowait()
            except queue_mod.Empty:
                break
            self.emit(Event(kind, folder, t))
        with self.lock:
            done = [(f, self.running.pop(f)) for f in [f for f in self.running if f.done()]]
        for fut, job in done:
            outcome = _outcome(fut, job, self.ctx)
            self.emit(Event(EventKind.FINISHED, outcome.job.folder, outcome=outcome))
            self.finished.append(outcome)

    def wait_any(self, timeout_s: float) -> None:
        """Block until a worker's run ends or `timeout_s` passes."""
        with self.lock:
            pending = list(self.running)
        if pending:
            wait(pending, timeout=timeout_s, return_when=FIRST_COMPLETED)
        else:
            time.sleep(timeout_s)

    def close(self) -> None:
        self.closed.set()
        self.dispatcher.join()
        self.ex.shutdown(wait=True, cancel_futures=True)
        self.events.close()


class Warm:
    """Worker processes kept from one call of `execute` to the next: a search runs many small
    batches, and a worker's start (a fresh interpreter importing kartci, 2-3 s of CPU) would
    otherwise be paid again for each. `close()` ends them; `execute` without a Warm starts
    and ends its own."""

    def __init__(self) -> None:
        self.workers: _Workers | None = None

    def take(self, ctx: Context, emit: Listener, n: int, todo: deque[Job]) -> _Workers:
        """The kept workers given this call's runs (or new ones, when none fit)."""
        kept = self.workers
        if kept is not None and kept.slots == n and not kept.closed.is_set():
            with kept.lock:
                kept.ctx, kept.emit, kept.todo = ctx, emit, todo
            return kept
        self.close()
        self.workers = _Workers(ctx, emit, n, todo)
        return self.workers

    def close(self) -> None:
        """End the kept workers, if any."""
        if self.workers is not None:
            self.workers.close()
            self.workers = None


def pool(jobs: Sequence[Job], ctx: Context, emit: Listener, workers: int,
         warm: Warm | None = None) -> Iterator[Outcome]:
    """`workers - 1` worker processes plus this one. This process has everything imported, so
    it starts the first (longest) run at once while the workers start up (2-3 s each), and it
    takes the next run whenever it is free. A hard crash (a segfault) in a run done here ends
    the whole command, as with -j 1; in a worker it is an error for that run only. With
    `warm`, the workers are kept for the next call."""
    todo = deque(jobs)
    mine: Job | None = todo.popleft()  # before a worker can take it
    n = workers - 1
    others = warm.take(ctx, emit, n, todo) if warm is not None else _Workers(ctx, emit, n, todo)
    done = False
    try:
        while True:
            others.tick()
            while others.finished:
                yield others.finished.popleft()
            if mine is not None:
                yield _here(mine, ctx, emit, others.tick)
            elif others.busy():
                others.wait_any(0.2)
            else:
                with others.lock:
                    if not others.todo:
                        break
            mine = others.take()
        done = True
    finally:
        if warm is None:
            others.close()
        elif not done:  # interrupted: runs may still be out with them
            warm.close()


def _outcome(fut: Future[Outcome], job: Job, ctx: Context) -> Outcome:
    try:
        return fut.result()
    except Exception as err:  # the worker process died (e.g. a segfault in native code)
        return lost(job, ctx, f"worker process failed: {type(err).__name__}: {err}")


def in_pinned_child(jobs: Sequence[Job], ctx: Context, emit: Listener,
                    workers: int) -> Iterator[Outcome]:
    """Every job in one pinned child process started as its own command (which runs them as
    a pinned `kartci run` would, its own workers included): this process was not started
    pinned, and a multiprocessing child would import its `__main__` again. Progress is not
    relayed; each outcome is announced when the child is done."""
    for outcome in call_pinned(ctx.project, outcomes, list(jobs), ctx, workers):
        emit(Event(EventKind.FINISHED, outcome.job.folder, outcome=outcome))
        yield outcome


def outcomes(jobs: list[Job], ctx: Context, workers: int) -> list[Outcome]:
    """Every job's outcome, executed here (the pinned child's work)."""
    return list(execute(jobs, ctx, _ignore, workers))


def _ignore(_: Event) -> None:
    pass


def execute(jobs: Sequence[Job], ctx: Context, emit: Listener, workers: int = 1,
            kind: ExecutorKind = ExecutorKind.LOCAL,
            ray_address: str | None = None, warm: Warm | None = None) -> Iterator[Outcome]:
    """Outcomes in the order jobs finish, each also announced as a FINISHED event. `warm`:
    local worker processes kept for the next call (see Warm)."""
    if kind is ExecutorKind.RAY:
        return ray_tasks(jobs, ctx, emit, workers, ray_address)
    if portable.state() is Pin.UNPINNED:  # this process's bits are not every CPU's
        return in_pinned_child(jobs, ctx, emit, workers)
    if workers <= 1 or len(jobs) <= 1:
        return serial(jobs, ctx, emit)
    return pool(jobs, ctx, emit, min(workers, len(jobs)), warm=warm)
