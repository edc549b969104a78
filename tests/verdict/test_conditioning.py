"""Chaos-aware baselines: each metric's spread over replicas started nanometres apart, recorded
by `baseline update`, widening a tolerance to at least 3x the spread and flagging a metric
whose spread exceeds its tolerance; and the platform a baseline was made on."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import QUICK, kartci

from kartci import portable
from kartci.project import current as active_project
from kartci.runner.jobs import START_STEP_M, Vary, replica
from kartci.scenario import load_scenario
from kartci.verdict import Conditioning, Status, load, spread, update
from kartci.verdict.baseline import judge


def _entry(value: float, tol: float, sp: float | None,
           direction: str = "higher") -> dict[str, object]:
    return {"value": value, "unit": "m", "tolerance": tol, "direction": direction, "spread": sp}


def test_spread_is_the_range_and_none_when_defined_in_some_replicas_only() -> None:
    assert spread([0.3, 0.1, 0.2]) == pytest.approx(0.2)
    assert spread([None, None]) == 0.0
    assert spread([0.3, None]) is None


@pytest.mark.parametrize(("sp", "value", "cond", "status"), [
    (0.001, 0.9, Conditioning.WELL, Status.REGRESSED),  # 3 x 0.001 < 0.066: tolerance as set
    (0.05, 0.9, Conditioning.MARGINAL, Status.PASS),  # widened to 0.15: -0.1 is chaos
    (0.14, 0.8, Conditioning.ILL, Status.PASS),  # spread > tolerance: flagged, widened to 0.42
    (None, 0.8, Conditioning.ILL, Status.REGRESSED),  # undefined in some replicas: no widening
])
def test_the_tolerance_is_at_least_three_spreads(sp: float | None, value: float,
                                                 cond: Conditioning, status: Status) -> None:
    v = judge(value, "m", "min_clearance_m", _entry(1.0, 0.066, sp))
    assert (v.conditioning, v.status) == (cond, status)
    assert v.tolerance == (0.066 if sp is None else max(0.066, 3 * sp))


def test_a_baseline_without_spread_is_unmeasured_and_judged_as_before() -> None:
    entry = {k: w for k, w in _entry(1.0, 0.066, 0.0).items() if k != "spread"}
    v = judge(0.9, "m", "min_clearance_m", entry)
    assert (v.conditioning, v.status, v.tolerance) == (Conditioning.UNMEASURED,
                                                       Status.REGRESSED, 0.066)


def test_update_records_spreads_and_where_it_was_made(tmp_path: Path) -> None:
    path = tmp_path / "q.json"
    made = {"platform": {"arch": "x86_64"}, "conditioning": {"replicas": 4}}
    update(path, "q", {"a_m": {"value": 1.0, "unit": "m"}, "b_m": {"value": 2.0, "unit": "m"}},
           {"a_m": 1.23456789e-9, "b_m": None}, made)
    data = json.loads(path.read_text())
    assert data["platform"] == {"arch": "x86_64"} and data["conditioning"] == {"replicas": 4}
    assert data["metrics"]["a_m"]["spread"] == 1.235e-9 and data["metrics"]["b_m"]["spread"] is None
    data["metrics"]["a_m"]["spread"] = -1
    path.write_text(json.dumps(data))
    with pytest.raises(Exception, match="spread must be a number >= 0"):
        load(path)


def test_a_start_replica_moves_every_robot_k_nanometres_and_nothing_else() -> None:
    spec = load_scenario("multi_agent", project=active_project())
    r = replica(spec, Vary.START, 3)
    for name, agent in spec.agents.items():
        assert r.agents[name].start.lateral_m == agent.start.lateral_m + 3 * START_STEP_M
        assert r.agents[name].model_dump(exclude={"start"}) == agent.model_dump(exclude={"start"})
    assert r.seed == spec.seed and replica(spec, Vary.SEED, 2).seed == spec.seed + 2


@pytest.mark.long(reason="several kartci runs end to end")
def test_conditioning_run_and_baseline_update_record_spreads(tmp_path: Path) -> None:
    """`run --conditioning 3` leaves 2 nudged replicas; `baseline update` runs the fourth,
    records every spread, the platform and how replicas were made. A later run against that
    baseline with a hand-tightened tolerance (below the spread) flags the metric ill-conditioned,
    and one made on another platform says so next to the verdict."""
    out, base = tmp_path / "out", tmp_path / "baselines"
    base.mkdir()
    run = kartci("run", "line_straight", *QUICK, "--conditioning", "3", "--out", out,
                 "--baselines", base)
    assert run.returncode == 0, run.stderr
    first = json.loads((out / "summary.json").read_text())["scenarios"]["line_straight"]
    # no baseline yet: each spread is judged against the tolerance the metric would get
    assert first["metrics"]["cross_track_rms_m"]["conditioning"] == "well"
    assert first["metrics"]["cross_track_rms_m"]["status"] == "new"
    for k in (1, 2):
        facts = json.loads((out / "line_straight" / f"repeat_{k}" / "run.json").read_text())
        assert facts["variation"] == {"vary": "start", "k": k, "step": START_STEP_M}
        assert facts["platform"]["simd"] == "pinned"
    upd = kartci("baseline", "update", out, "--baselines", base)
    assert upd.returncode == 0, upd.stderr
    assert "running 1 conditioning replicas" in upd.stderr and "worst-conditioned:" in upd.stdout
    data = json.loads((base / "line_straight.json").read_text())
    assert data["conditioning"]["replicas"] == 4 and data["conditioning"]["step_m"] == 1e-9
    assert data["platform"]["numpy"] == portable.describe()["numpy"]
    metrics = data["metrics"]
    assert all("spread" in m for m in metrics.values())
    # the line tracker's start nudged by nanometres: its cross-track error moves, but far less
    # than any tolerance (a well-conditioned scenario)
    xt = metrics["cross_track_rms_m"]
    assert 0 < xt["spread"] < xt["tolerance"] / 3
    xt["tolerance"] = xt["spread"] / 2
    data["platform"].update(arch="aarch64", numpy="2.3.0")
    (base / "line_straight.json").write_text(json.dumps(data))
    again = kartci("run", "line_straight", *QUICK, "--out", out, "--baselines", base)
    assert again.returncode == 0, again.stderr
    summary = json.loads((out / "summary.json").read_text())["scenarios"]["line_straight"]
    assert summary["metrics"]["cross_track_rms_m"]["conditioning"] == "ill"
    assert summary["metrics"]["completion"]["conditioning"] == "well"
    assert any("cross_track_rms_m is ill-conditioned" in w for w in summary["warnings"])
    assert "ILL-CONDITIONED" in again.stdout and "conditioning" in (out / "report.html").read_text()
    note = next(w for w in summary["warnings"] if w.startswith("baseline made elsewhere"))
    assert "arch aarch64 (this run: " in note and "numpy 2.3.0" in note
    assert "baseline made elsewhere" in (out / "summary.md").read_text()


@pytest.mark.long(reason="kartci runs end to end")
def test_baseline_update_refuses_a_run_with_native_kernels(tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert kartci("run", "line_straight", *QUICK, "--out", out, "--baselines", tmp_path,
                  env={"KARTCI_SIMD": "native"}).returncode == 0
    upd = kartci("baseline", "update", out, "--baselines", tmp_path / "b")
    assert upd.returncode == 2 and "native SIMD kernels" in upd.stderr
    assert len(upd.stderr.strip().splitlines()) == 1 and not (tmp_path / "b").exists()
