"""Progress of a run: a live table on a terminal, one line per finished job in CI logs."""

from __future__ import annotations

import time
from dataclasses import dataclass
from enum import StrEnum
from types import TracebackType

from rich.console import Console
from rich.live import Live
from rich.table import Table
from rich.text import Text

from kartci.report.tables import marked, num
from kartci.runner import Event, EventKind, Job
from kartci.verdict import Status


class JobState(StrEnum):
    """Where a job is, as the progress view shows it."""

    QUEUED = "queued"
    RUNNING = "running"
    DONE = "done"


@dataclass
class _Row:
    duration_s: float
    state: JobState = JobState.QUEUED
    sim_t: float = 0.0
    started: float = 0.0
    rtf: float | None = None
    status: Status | None = None


class ProgressView:
    """Listens to runner events. `live` (a terminal) redraws a table four times a second;
    otherwise each finished job prints one line, so CI logs stay short."""

    def __init__(self, jobs: list[Job], console: Console, live: bool) -> None:
        self.console = console
        self.rows = {j.folder: _Row(j.spec.duration_s) for j in jobs}
        self.live = Live(get_renderable=self._table, console=console, refresh_per_second=4,
                         transient=True) if live else None

    def __enter__(self) -> ProgressView:
        if self.live is not None:
            self.live.start()
        return self

    def __exit__(self, kind: type[BaseException] | None, err: BaseException | None,
                 tb: TracebackType | None) -> None:
        if self.live is not None:
            self.live.stop()

    def __call__(self, ev: Event) -> None:
        """Update a job's row from a runner event; print a line when the job finishes."""
        row = self.rows.get(ev.folder)
        if row is None or row.state is JobState.DONE:
            return  # late news from a worker about a job already finished
        if ev.kind is EventKind.STARTED or row.state is JobState.QUEUED:
            row.state, row.started = JobState.RUNNING, time.perf_counter()
        if ev.kind is EventKind.PROGRESS:
            row.sim_t = ev.sim_t
            wall = time.perf_counter() - row.started
            row.rtf = ev.sim_t / wall if wall > 0 else None
        if ev.kind is EventKind.FINISHED and ev.outcome is not None:
            o = ev.outcome
            row.state = JobState.DONE
            row.sim_t = float(o.run.get("sim_time_s") or row.sim_t)
            row.rtf = o.run.get("real_time_factor")
            row.status = (o.result.status if o.result is not None else
                          Status.ERROR if o.error else Status.PASS)
            line = (f"{ev.folder}: {marked(row.status)} (sim "
                    f"{num(o.run.get('sim_time_s'), 's')}, {num(row.rtf)}x real time)")
            if o.error:
                line += f": {o.error}"
            self.console.print(line, highlight=False, markup=False)

    def counts(self) -> dict[JobState, int]:
        """How many jobs are in each state."""
        return {s: sum(r.state is s for r in self.rows.values()) for s in JobState}

    def _table(self) -> Table:
        c = self.counts()
        table = Table("scenario", "state", "sim time", "real-time factor", box=None,
                      title=f"done {c[JobState.DONE]} · running {c[JobState.RUNNING]} · "
                            f"queued {c[JobState.QUEUED]}", title_justify="left")
        for folder, r in self.rows.items():
            if r.state is JobState.DONE:
                continue  # already printed as a line above the table
            table.add_row(Text(folder), r.state.value,
                          f"{r.sim_t:6.1f} / {r.duration_s:g} s" if r.state is JobState.RUNNING
                          else "", num(r.rtf) if r.state is JobState.RUNNING else "")
        return table
