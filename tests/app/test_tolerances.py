"""`kartci baseline tolerances`: proposals from a faults folder's runs and a baseline, checked
against the rule written out by hand (floor 3 x spread or the metric's resolution, half the
smallest move a fault makes that today's tolerance lets pass, else kept), the matrix re-judged
as `kartci compare` judges, and the files written."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from helpers import kartci

from kartci.app.tolerances import Why, propose, write
from kartci.errors import SpecError


def metric(value: float, unit: str = "s") -> dict[str, Any]:
    return {"value": value, "unit": unit}


def entry(value: float, tolerance: float, spread: float, direction: str = "lower",
          unit: str = "s") -> dict[str, Any]:
    return {"value": value, "tolerance": tolerance, "spread": spread, "direction": direction,
            "unit": unit}


@pytest.fixture
def case(tmp_path: Path) -> tuple[Path, Path]:
    """A faults folder of one scenario (q) and two faults, and its baselines:
    - settle_time_s (lower, tol 0.5, spread 0.01): slow +0.24 (passes today), weak +1.2;
    - lap_s (lower, tol 0.1, spread 0.05: ill-conditioned, floor 0.15): slow +0.12, weak +0.3;
    - speed_mps (higher, tol 0.2, spread 0): slow -0.5 (caught today), weak +0.1 (better);
    - ok (equal, tol 1, spread 0): no fault moves it;
    - mean_speed_mps (higher, registered: default tolerance 0.002 m/s at 0.1, so resolution
      0.0002; tol 4.4e-8, below it): slow -1e-7 (float digits), weak -0.001."""
    out, base = tmp_path / "faults", tmp_path / "baselines"
    runs = {"q": {"settle_time_s": 0.84, "lap_s": 10.0, "speed_mps": 5.0, "ok": 1.0,
                  "mean_speed_mps": 0.1},
            "q@fault=r.slow": {"settle_time_s": 1.08, "lap_s": 10.12, "speed_mps": 4.5,
                               "ok": 1.0, "mean_speed_mps": 0.1 - 1e-7},
            "q@fault=r.weak": {"settle_time_s": 2.04, "lap_s": 10.3, "speed_mps": 5.1,
                               "ok": 1.0, "mean_speed_mps": 0.099}}
    for label, values in runs.items():
        (out / label).mkdir(parents=True)
        (out / label / "metrics.json").write_text(json.dumps(
            {"metrics": {k: metric(v) for k, v in values.items()}}))
    (out / "summary.json").write_text(json.dumps({"kartci_faults": 1, "cells": [
        {"fault": "r.slow", "scenario": "q", "result": "missed", "run": "q@fault=r.slow"},
        {"fault": "r.weak", "scenario": "q", "result": "caught", "run": "q@fault=r.weak"},
        {"fault": "r.none", "scenario": "q", "result": "not applicable", "run": None}]}))
    base.mkdir()
    (base / "q.json").write_text(json.dumps({"scenario": "q", "metrics": {
        "settle_time_s": entry(0.84, 0.5, 0.01), "lap_s": entry(10.0, 0.1, 0.05),
        "speed_mps": entry(5.0, 0.2, 0.0, "higher", "m/s"),
        "ok": entry(1.0, 1.0, 0.0, "equal", ""),
        "mean_speed_mps": entry(0.1, 4.4e-8, 0.0, "higher", "m/s")}}))
    return out, base


def test_each_metric_gets_the_width_the_rule_gives(case: tuple[Path, Path]) -> None:
    out, base = case
    result = propose(out, base)
    why = {p.metric: p.why for p in result.proposals}
    width = {p.metric: p.proposed for p in result.proposals}
    assert why == {"settle_time_s": Why.TIGHTENED, "lap_s": Why.WIDENED,
                   "speed_mps": Why.KEPT,  # it catches the one fault that moves it
                   "ok": Why.KEPT,  # nothing moves it: no evidence to tighten
                   "mean_speed_mps": Why.RESOLVED}  # a gate on float digits
    assert width == pytest.approx({"settle_time_s": 0.12,  # 0.24 / 2
                                   "lap_s": 0.15,  # 3 x 0.05
                                   "speed_mps": 0.2, "ok": 1.0,
                                   "mean_speed_mps": 0.0002})  # 0.1 x 0.002
    speed = next(p for p in result.proposals if p.metric == "mean_speed_mps")
    assert [f for f, _ in speed.moved_by] == ["r.weak"]  # r.slow's 1e-7 is below resolution
    settle = next(p for p in result.proposals if p.metric == "settle_time_s")
    assert [f for f, _ in settle.moved_by] == ["r.slow", "r.weak"]
    # r.slow: today lap_s (0.12 > 0.1, inside its chaos) and speed_mps catch it; proposed,
    # settle_time_s does and lap_s no longer (0.12 < its floor 0.15)
    # mean_speed_mps caught r.slow by 1e-7 m/s today, and no longer
    cells = {c.fault: (c.caught_now, c.caught_proposed) for c in result.cells}
    assert cells["r.slow"] == (("lap_s", "mean_speed_mps", "speed_mps"),
                               ("settle_time_s", "speed_mps"))
    assert set(cells["r.weak"][1]) == {"settle_time_s", "lap_s", "mean_speed_mps"}
    assert result.score(proposed=False) == result.score(proposed=True) == (2, 2)
    assert result.unseen() == []


def test_written_tolerances_are_the_proposals_and_nothing_else(case: tuple[Path, Path]) -> None:
    out, base = case
    before = json.loads((base / "q.json").read_text())
    assert write(propose(out, base), base) == [base / "q.json"]
    after = json.loads((base / "q.json").read_text())
    assert after["metrics"]["settle_time_s"]["tolerance"] == pytest.approx(0.12)
    assert after["metrics"]["lap_s"]["tolerance"] == pytest.approx(0.15)
    for doc in (before, after):
        for m in doc["metrics"].values():
            del m["tolerance"]
    assert before == after
    assert propose(out, base).changed() == []  # proposals are a fixed point


def test_the_command_prints_and_writes_and_bad_input_is_one_line(case: tuple[Path, Path],
                                                                 tmp_path: Path) -> None:
    out, base = case
    p = kartci("baseline", "tolerances", out, "--baselines", base, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    assert "q: settle_time_s: 0.5 -> 0.12 s (tightened; floor 0.05; r.slow +0.24" in p.stdout
    assert ("q: mean_speed_mps: 4.4e-08 -> 0.0002 m/s (widened to its resolution; floor "
            "0.0002; r.weak +0.001)") in p.stdout
    assert "detection: 2/2 faults caught at today's tolerances, 2/2 at the proposed ones" \
        in p.stdout
    assert json.loads((base / "q.json").read_text())["metrics"]["lap_s"]["tolerance"] == 0.1
    p = kartci("baseline", "tolerances", out, "--baselines", base, "--write", cwd=tmp_path)
    assert p.returncode == 0 and f"wrote {base / 'q.json'}" in p.stderr
    bad = kartci("baseline", "tolerances", tmp_path / "nothing", "--baselines", base,
                 cwd=tmp_path)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert "no detection matrix to read" in bad.stderr and len(bad.stderr.splitlines()) == 1
    (base / "q.json").unlink()
    with pytest.raises(SpecError, match="q: no baseline in"):
        propose(out, base)
