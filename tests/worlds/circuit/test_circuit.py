"""The circuit world: a TUMFTM track alone with barriers; and the hall refusing a track that
runs through its walls."""

from __future__ import annotations

from pathlib import Path

import pytest

from kartci.errors import SpecError
from kartci.metrics import compute
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim import simulate


def test_a_kart_steered_off_the_circuit_hits_the_barrier(tmp_path: Path) -> None:
    """kart_wall's script (full right lock from the start) on the club circuit: the barrier
    outside the right edge stops it, and the collision names the barrier."""
    spec = load_scenario("kart_wall", ["world=club/circuit", "duration_s=6"],
                         project=active_project())
    simulate(spec, tmp_path / "run.mcap")
    m = compute(tmp_path / "run.mcap")[1]
    others = {e["other"].rsplit("_", 1)[0] for e in m["collisions"].extra["events"]}
    assert m["collisions"].value >= 1 and others == {"barrier_right"}


def test_without_barriers_the_same_kart_hits_nothing(tmp_path: Path) -> None:
    spec = load_scenario("kart_wall", ["world=club/circuit", "world.barriers=false",
                                       "duration_s=6"], project=active_project())
    simulate(spec, tmp_path / "run.mcap")
    m = compute(tmp_path / "run.mcap")[1]
    assert m["collisions"].value == 0 and m["off_track_s"].value > 1.0


def test_the_hall_refuses_a_track_through_its_walls(tmp_path: Path) -> None:
    spec = load_scenario("kart_wall", ["world.track=tracks/club.csv", "duration_s=1"],
                         project=active_project())
    with pytest.raises(SpecError, match=r"track club.csv runs through (wall|pillar)_\w+ at .*"
                                        r"kind: circuit"):
        simulate(spec, tmp_path / "run.mcap")
    assert not (tmp_path / "run.mcap").exists()


def test_a_run_on_another_track_is_judged_against_that_tracks_baseline(
        tmp_path: Path) -> None:
    """`--set world.track=...` (or `world=...`) is a different run: its label and folder say
    so, and the original scenario's baseline never judges it."""
    from kartci.runner import expand

    jobs = expand(["kart_wall"], ["world.track=tracks/chicane.csv"], active_project())
    assert [j.label for j in jobs] == ["kart_wall@track=chicane"]
    jobs = expand(["kart_wall"], ["world=club/circuit"], active_project(), ["duration_s=1,2"])
    assert [j.label for j in jobs] == ["kart_wall@world=club_circuit,duration_s=1",
                                       "kart_wall@world=club_circuit,duration_s=2"]
    assert [j.label for j in expand(["kart_wall"], ["duration_s=1"],
                                    active_project())] == ["kart_wall"]
