"""What every executor shares (the in-process and pooled ones in executors, Ray's in
ray_executor): the events it reports to progress listeners, and the outcome of a job whose
process died."""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum

from kartci.core import RunFolder
from kartci.runner.jobs import Context, Job, Outcome


class EventKind(StrEnum):
    """What an Event reports."""

    STARTED = "started"
    PROGRESS = "progress"
    FINISHED = "finished"


@dataclass(frozen=True)
class Event:
    """News of one job, for progress listeners."""

    kind: EventKind
    folder: str  # the job's folder, relative to OUT
    sim_t: float = 0.0
    outcome: Outcome | None = None  # FINISHED only


Listener = Callable[[Event], None]


def lost(job: Job, ctx: Context, error: str) -> Outcome:
    """A job whose process died: its folder is marked failed here, since the dead process
    could not (its own unfinished mark says no more than that it did not finish)."""
    folder = RunFolder(ctx.out / job.folder)
    if folder.path.is_dir():
        folder.mark_failed(job.label, error)
        for stage in folder.stages():  # its half-written run: nobody owns it
            shutil.rmtree(stage, ignore_errors=True)
    return Outcome.failed(job, error)
