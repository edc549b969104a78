"""Progress: worker processes report sim time; a terminal gets a live table, CI one line each."""

from __future__ import annotations

import io
from pathlib import Path

from helpers import PAIR
from rich.console import Console

from kartci.project import current as active_project
from kartci.report.progress import JobState, ProgressView
from kartci.runner import Event, EventKind, Outcome, expand, run_jobs


def test_pool_workers_report_start_sim_time_and_end(tmp_path: Path, baselines: Path) -> None:
    events: list[Event] = []
    jobs = expand(PAIR, ["duration_s=2.5", "criteria={}", "metrics.line_tracking.transient_s=0.5"],
                  active_project())
    run_jobs(jobs, tmp_path, baselines, active_project(), workers=2, on_event=events.append)
    for name in PAIR:
        mine = [e for e in events if e.folder == name]
        kinds = [e.kind for e in mine]
        assert kinds[0] is EventKind.STARTED and kinds[-1] is EventKind.FINISHED
        times = [e.sim_t for e in mine if e.kind is EventKind.PROGRESS]
        assert times == sorted(times) and times[-1] >= 2.0  # one report per simulated second


def _console(terminal: bool) -> tuple[Console, io.StringIO]:
    buf = io.StringIO()
    return Console(file=buf, width=200, force_terminal=terminal, color_system=None), buf


def test_ci_view_prints_one_line_per_finished_job() -> None:
    jobs = expand(PAIR, [], active_project())
    console, buf = _console(False)
    with ProgressView(jobs, console, live=False) as view:
        view(Event(EventKind.STARTED, "line_circle"))
        view(Event(EventKind.PROGRESS, "line_circle", 3.0))
        assert buf.getvalue() == ""  # quiet while running
        view(Event(EventKind.FINISHED, "line_circle", outcome=Outcome(
            jobs[1], run={"sim_time_s": 26.0, "real_time_factor": 5.2})))
        view(Event(EventKind.FINISHED, "line_straight", outcome=Outcome(jobs[0], "boom")))
    lines = buf.getvalue().splitlines()
    assert lines == ["line_circle: pass (sim 26 s, 5.2x real time)",
                     "line_straight: ERROR (sim —, —x real time): boom"]


def test_live_view_counts_done_running_queued() -> None:
    jobs = expand(PAIR, [], active_project(), repeat=2)
    console, buf = _console(True)
    with ProgressView(jobs, console, live=True) as view:
        view(Event(EventKind.STARTED, "line_circle"))
        view(Event(EventKind.PROGRESS, "line_circle", 4.0))
        view(Event(EventKind.FINISHED, "line_straight/repeat_1", outcome=Outcome(jobs[1])))
        assert view.counts() == {JobState.DONE: 1, JobState.RUNNING: 1, JobState.QUEUED: 2}
        console.print(view._table())
    text = buf.getvalue()
    assert "done 1 · running 1 · queued 2" in text
    assert "4.0 / 26 s" in text
