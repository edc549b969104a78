"""Verdict rules: directions, tolerances, missing values, per-agent criteria."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from kartci.project import current as active_project
from kartci.robots.line_tracker.metrics import LineMetricsParams, line_metrics
from kartci.scenario import Criterion, load_scenario
from kartci.verdict import Status, check_criteria, compare, update
from kartci.verdict import load as load_baseline


def _entry(value: float | None, tol: float, direction: str) -> dict[str, object]:
    return {"value": value, "tolerance": tol, "direction": direction, "unit": "m"}


@pytest.mark.parametrize(("value", "direction", "status"), [
    (1.05, "lower", Status.PASS), (1.2, "lower", Status.REGRESSED),
    (0.8, "lower", Status.IMPROVED), (0.8, "higher", Status.REGRESSED),
    (1.2, "higher", Status.IMPROVED), (1.2, "equal", Status.REGRESSED),
    (1.0, "equal", Status.PASS),
])
def test_directions_and_tolerances(value: float, direction: str, status: Status) -> None:
    [v] = compare({"m": {"value": value, "unit": "m"}}, {"m": _entry(1.0, 0.1, direction)})
    assert v.status is status


def test_new_and_missing_and_null() -> None:
    got = compare({"a": {"value": 1.0}, "c": {"value": None}},
                  {"b": _entry(1.0, 0.1, "lower"), "c": _entry(None, 0.0, "lower")})
    assert {v.name: v.status for v in got} == {"a": Status.NEW, "b": Status.MISSING,
                                               "c": Status.PASS}


def test_criteria_apply_to_every_agent() -> None:
    metrics = {"lt0.line_lost": {"value": 0.0}, "lt1.line_lost": {"value": 1.0}}
    res = check_criteria(metrics, {"line_lost": Criterion(equal=0.0)})
    assert [(r.name, r.ok) for r in res] == [("lt0.line_lost", True), ("lt1.line_lost", False)]


def test_update_keeps_hand_tolerance_but_replaces_one_set_on_a_null(tmp_path: Path) -> None:
    path = tmp_path / "s.json"
    update(path, "s", {"settle_time_s": {"value": None, "unit": "s"},
                       "cross_track_rms_m": {"value": 0.01, "unit": "m"}})
    first = load_baseline(path)
    assert first is not None and first["settle_time_s"]["tolerance"] == 0.5  # not 0
    first["cross_track_rms_m"]["tolerance"] = 0.123
    path.write_text(__import__("json").dumps({"metrics": first}))
    update(path, "s", {"settle_time_s": {"value": 2.0, "unit": "s"},
                       "cross_track_rms_m": {"value": 0.02, "unit": "m"}})
    second = load_baseline(path)
    assert second is not None
    assert second["cross_track_rms_m"]["tolerance"] == 0.123
    assert second["settle_time_s"]["tolerance"] == 0.5


def test_circle_completion_counts_one_lap_from_any_start() -> None:
    spec = load_scenario("line_circle", ["agents.lt0.start.along_m=2.0"], project=active_project())
    r = spec.world.course.radius_m  # type: ignore[attr-defined]
    import numpy as np

    a0 = -np.pi / 2 + 2.0 / r
    a = a0 + np.linspace(0, 2 * np.pi * 1.01, 400)
    lever = spec.agents["lt0"].model.sensor_point_x_m  # type: ignore[attr-defined]
    yaw = a + np.pi / 2
    odom = pd.DataFrame({"t": np.linspace(0, 30, 400), "x": r * np.cos(a) - lever * np.cos(yaw),
                         "y": r * np.sin(a) - lever * np.sin(yaw), "yaw": yaw, "vx": 0.1})
    m = {x.name: x for x in line_metrics(spec, "lt0", odom, LineMetricsParams())}
    assert m["completion"].value == pytest.approx(1.0)
    assert m["line_lost"].value == 0
