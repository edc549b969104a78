"""The MPCC: its compiled-solver cache, its reaction to its inputs, other tracks, failures,
and the racing metrics computed from its logs."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from helpers import bullet_gaps_m

from kartci.logs import tables
from kartci.metrics import Metric, compute
from kartci.metrics.outline import outline_gap_m, placed
from kartci.metrics.progress import kart_track
from kartci.project import BUILTIN_SIMS
from kartci.project import current as active_project
from kartci.robots.gokart.mpcc.cache import get_solver, solver_key
from kartci.robots.gokart.mpcc.model import SingleTrack
from kartci.robots.gokart.mpcc.params import MpccController, MpccMethod, MpccWeights
from kartci.robots.gokart.params import GokartModel
from kartci.scenario import load_scenario
from kartci.sim import simulate
from kartci.worlds.track import load_track


def _run(tmp_path: Path, name: str, *sets: str) -> tuple[Path, dict[str, Metric]]:
    log = tmp_path / f"{name}.mcap"
    simulate(load_scenario(name, list(sets), project=active_project()), log)
    return log, compute(log)[1]


@pytest.mark.long(reason="compiles each solver: about 10 s (RTI) and 30 s (Ipopt) of C")
@pytest.mark.parametrize("method", list(MpccMethod))
def test_solver_is_compiled_once_then_loaded_from_the_cache(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, method: MpccMethod) -> None:
    monkeypatch.setenv("KARTCI_CACHE_DIR", str(tmp_path))
    spec = MpccController(horizon_steps=8, method=method)
    kart = SingleTrack.of(GokartModel())
    first = get_solver(spec, kart)
    assert first.compiled and not first.cache_hit
    assert len(list((tmp_path / "mpcc").glob(f"mpcc_{method}_*.so"))) == 1
    second = get_solver(spec, kart)
    assert second.cache_hit
    assert (second.rti is not None) == (method is MpccMethod.RTI)
    # tuning and limits are solver inputs: they reuse the binary; the horizon and the kart's
    # own parameters (the model reads them from the robot) do not
    key = solver_key(spec, kart)
    assert solver_key(spec.model_copy(update={"weights": MpccWeights(lag=5.0),
                                              "max_speed_mps": 3.0}), kart) == key
    assert solver_key(spec.model_copy(update={"horizon_steps": 9}), kart) != key
    assert solver_key(spec, SingleTrack.of(GokartModel(yaw_inertia_kgm2=30.0))) != key


@pytest.mark.long(reason="closed-loop MPCC laps")
def test_a_lower_speed_limit_lowers_the_top_speed(tmp_path: Path) -> None:
    _, fast = _run(tmp_path, "mpcc_lap", "duration_s=6")
    _, slow = _run(tmp_path, "mpcc_lap", "duration_s=6",
                   "agents.kart0.controller.max_speed_mps=4.0")
    assert fast["max_speed_mps"].value > 6.0
    assert slow["max_speed_mps"].value == pytest.approx(4.0, abs=0.3)


@pytest.mark.parametrize(("lateral", "side"), [(0.3, -1), (-0.5, 1)])
def test_an_obstacle_moved_by_set_moves_the_path(tmp_path: Path, lateral: float,
                                                  side: int) -> None:
    """One box on the main straight (s = 7 m): the kart passes on the side with more room."""
    track = load_track(BUILTIN_SIMS / "winti" / "track.csv")
    x, y, _ = track.pose_at(7.0, lateral)
    log, m = _run(tmp_path, "mpcc_lap", "duration_s=4",
                  f"world.obstacles=[{{center_m: [{x}, {y}], size_m: [0.5, 0.5, 0.5]}}]")
    path = kart_track(track, tables(log)["/kart0/odom"])
    at = path[(path["s_total"] > 6.5) & (path["s_total"] < 7.5)]
    assert len(at) > 0
    assert (side * at["offset"] > 0.3).all()
    assert m["collisions"].value == 0
    assert m["min_clearance_m"].value > 0.1


@pytest.mark.long(reason="closed-loop MPCC laps")
@pytest.mark.parametrize("name", ["hairpins", "sweepers", "chicane"])
def test_the_same_mpcc_laps_other_tracks(tmp_path: Path, name: str) -> None:
    _, m = _run(tmp_path, "mpcc_lap", f"world.track=tracks/{name}.csv", "duration_s=17")
    assert m["laps_completed"].value >= 1
    assert m["collisions"].value == 0
    assert m["off_track_s"].value == 0
    assert m["solver_failures"].value == 0


def test_failed_solves_brake_and_are_counted(tmp_path: Path) -> None:
    """The Ipopt reference mode (a short horizon: a short compile): an iteration cap no solve
    can meet fails every solve, the kart never gets going. (RTI: test_rti.py.)"""
    log, m = _run(tmp_path, "mpcc_lap", "duration_s=2",
                  "agents.kart0.controller.method=ipopt",
                  "agents.kart0.controller.horizon_steps=8",
                  "agents.kart0.controller.max_iterations=1")
    stats = tables(log)["/kart0/mpcc/stats"]
    assert m["solver_failures"].value == len(stats) == 41  # 2 s at 20 Hz, both ends
    assert not stats["success"].any()
    assert m["progress_m"].value < 0.5


@pytest.mark.long(reason="the full multi_agent race, shared with its exact-baseline check")
def test_two_karts_in_their_own_namespaces_and_the_mpcc_passes(
        shipped_run: Callable[[str], Path]) -> None:
    """kart0 passes kart1; their clearance is outline to outline: PyBullet's
    distance between the two karts' collision shapes at the logged poses, never more than the
    chassis box alone (the old footprint) gives."""
    log = shipped_run("multi_agent")
    m, t = compute(log)[1], tables(log)
    assert {"/kart0/odom", "/kart1/odom", "/kart0/mpcc/stats", "/kart1/joy",
            "/kart0/tyres"} <= set(t)
    assert "/kart1/mpcc/stats" not in t
    # the pass at about 4.5 s, and the lapping pass at about 22 s (kart1 starts 12 m ahead on
    # the 64.3 m track; from 10 m the lapping pass fell on the run's end)
    assert m["kart0.overtakes"].value == 2
    assert m["kart1.overtakes"].value == -2
    assert m["kart0.collisions"].value == 0
    a, b = (t[f"/{k}/odom"][["x", "y", "yaw"]].to_numpy() for k in ("kart0", "kart1"))
    near = np.hypot(*(a[:, :2] - b[:, :2]).T) < 4.0
    bullet = float(bullet_gaps_m(a[near], b[near]).min())
    clearance = m["kart0.min_clearance_m"].value
    assert bullet - 2e-3 <= clearance <= bullet
    # the chassis box alone never comes closer than the outline with its wheels; at this
    # pass's closest approach the chassis boxes are the nearest parts and the two coincide
    chassis = (((-0.4, -0.6), (1.6, -0.6), (1.6, 0.6), (-0.4, 0.6)),)
    assert float(outline_gap_m(placed(chassis, a), placed(chassis, b)).min()) >= clearance
    assert 0.1 < clearance == m["kart1.min_clearance_m"].value
