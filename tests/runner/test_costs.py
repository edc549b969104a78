"""The run order of `-j N`: longest last wall time first, unseen scenarios estimated from their
sim duration, and the learned times kept across runs in the cache folder."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from kartci.project import current as active_project
from kartci.runner import costs, expand
from kartci.runner.jobs import Job, Outcome


@pytest.fixture(autouse=True)
def _cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("KARTCI_CACHE_DIR", str(tmp_path))


def _jobs() -> dict[str, Job]:
    return {j.label: j for j in expand(["line_straight", "kart_wall", "mpcc_lap"], [],
                                       active_project())}


def test_without_timings_the_longest_simulation_goes_first() -> None:
    jobs = _jobs()
    assert [j.label for j in costs.order(list(jobs.values()))] == [
        "mpcc_lap", "line_straight", "kart_wall"]  # 42 s, 26 s and 6 s of sim time


def test_learned_wall_times_set_the_order_and_unseen_ones_use_the_median_speed() -> None:
    jobs = _jobs()
    # kart_wall was slow (6 s sim in 30 s wall), line_straight fast (26 s in 1.2 s)
    costs.remember([Outcome(jobs["kart_wall"], run={}, job_s=30.0),
                    Outcome(jobs["line_straight"], run={}, job_s=1.2)])
    known = costs.load()
    assert known == {costs.key(jobs["kart_wall"]): (30.0, 6.0),
                     costs.key(jobs["line_straight"]): (1.2, 26.0)}
    # mpcc_lap unseen: 42 s at the median real-time factor of (0.2x, 21.7x) -> 3.8 s
    assert costs.estimate_s(jobs["mpcc_lap"], known) == pytest.approx(42 / ((0.2 + 26 / 1.2) / 2))
    assert [j.label for j in costs.order(list(jobs.values()))] == [
        "kart_wall", "mpcc_lap", "line_straight"]


def test_failed_runs_and_repeats_teach_nothing_and_a_broken_file_is_ignored(
        tmp_path: Path) -> None:
    jobs = _jobs()
    repeat = expand(["kart_wall"], [], active_project(), repeat=2)[1]
    costs.remember([Outcome(jobs["kart_wall"], error="boom", job_s=99.0),
                    Outcome(repeat, job_s=50.0)])
    assert not (tmp_path / costs.FILE).exists()
    costs.remember([Outcome(jobs["kart_wall"], job_s=2.0)])
    costs.remember([Outcome(jobs["line_straight"], job_s=1.0)])  # merged, not replaced
    assert set(json.loads((tmp_path / costs.FILE).read_text())) == {
        costs.key(jobs["kart_wall"]), costs.key(jobs["line_straight"])}
    (tmp_path / costs.FILE).write_text("{not json")
    assert costs.load() == {}
    assert costs.order([jobs["kart_wall"], jobs["mpcc_lap"]])[0].label == "mpcc_lap"


def test_a_shortened_run_teaches_nothing_about_the_full_scenario() -> None:
    full = _jobs()["mpcc_lap"]
    short = expand(["mpcc_lap"], ["duration_s=2"], active_project())[0]
    assert short.label == full.label == "mpcc_lap"
    costs.remember([Outcome(short, job_s=0.5)])
    assert costs.estimate_s(short, costs.load()) == 0.5
    assert costs.estimate_s(full, costs.load()) == pytest.approx(42 / (2 / 0.5))


def test_only_the_most_recent_entries_are_kept(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(costs, "KEEP", 2)
    jobs = _jobs()
    for name in ("kart_wall", "line_straight", "mpcc_lap", "kart_wall"):
        costs.remember([Outcome(jobs[name], job_s=1.0)])
    assert set(costs.load()) == {costs.key(jobs["mpcc_lap"]), costs.key(jobs["kart_wall"])}
