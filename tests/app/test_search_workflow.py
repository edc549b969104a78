"""Issue 44, `kartci search` around the search: axes checked against the scenario (bad input is
one line and exit 2), found.yaml runnable as a scenario, the page, and resuming an interrupted
search from its journal."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
from helpers import kartci

from kartci.app.search import Options, Request, make_axes, run_search
from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.runner.search import AxisKind, Evaluation, Phase, Point, RunStatus
from kartci.scenario import load_scenario
from kartci.scenario.load import scenario_loader
from kartci.scenario.models import Criterion
from kartci.verdict.baseline import check_criteria

PERIOD = "agents.lt0.controller.period_s"
KP = "agents.lt0.controller.kp"


@pytest.mark.parametrize(("args", "expected"), [
    ([f"{PERIOD[:-2]}x=0.01..0.1"], r"unknown key \(did you mean 'period_s'\?\)"),
    ([f"{PERIOD}=-0.01..0.1"], r"-0.01 is refused: .*must be more than 0"),
    ([f"{PERIOD}=0.01..0.1", "--budget", "20000"],
     r"--budget 20,000: more than the 10,000 runs allowed"),
])
def test_bad_search_input_is_one_line_naming_it_and_exit_2(args: list[str], expected: str,
                                                           tmp_path: Path) -> None:
    proc = kartci("search", "line_circle", "--over", *args, "--out", tmp_path / "out")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert re.search(expected, lines[0]), lines[0]
    assert not list((tmp_path / "out").glob("line_circle@*"))  # nothing ran


@pytest.mark.parametrize(("over", "objective", "expected"), [
    (f"{PERIOD}=0.1..0.01", "criteria", r"the low end must be below the high end"),
    (f"{PERIOD}=fast", "criteria", r"expected LOW..HIGH"),
    (f"{PERIOD}=0.01..0.1:0.003", "criteria",
     r"0.013 is refused: .*whole multiple of physics.dt_s"),
    (f"{PERIOD}=0.01..0.1", "cross_trak_max_m",
     r"not 'criteria' nor a known metric \(did you mean 'cross_track_max_m'\?\)"),
    (f"{PERIOD}=0.01..0.1", "line_lost", r"has no worse direction"),
])
def test_a_bad_axis_or_objective_is_refused_before_any_run(over: str, objective: str,
                                                           expected: str, tmp_path: Path) -> None:
    ran: list[Point] = []

    def run(points: list[Point], phase: Phase) -> list[Evaluation]:
        ran.extend(points)
        return _fake(points, phase)

    with pytest.raises(SpecError, match=expected):
        run_search(Request("line_circle", (over,), objective=objective), tmp_path,
                   Options(tmp_path, active_project()), evaluate=run)
    assert ran == []


def test_a_criterion_margin_is_the_room_left_as_a_fraction_of_its_bound() -> None:
    values = {"x": {"value": 0.006}, "n": {"value": 2.0}, "c": {"value": 0.9}}
    got = {c.name: c for c in check_criteria(values, {
        "x": Criterion(max=0.008), "n": Criterion(equal=0), "c": Criterion(min=0.95)})}
    assert got["x"].ok and got["x"].margin == pytest.approx(0.25)  # 0.002 of 0.008
    assert not got["n"].ok and got["n"].margin == pytest.approx(-2.0)  # 2 units off == 0
    assert not got["c"].ok and got["c"].margin == pytest.approx(-0.05 / 0.95)
    held = check_criteria({"n": {"value": 0.0}}, {"n": Criterion(equal=0)})[0]
    assert held.ok and held.margin == math.inf  # an equality that holds grades nothing
    missing = check_criteria({}, {"x": Criterion(max=1.0)})[0]
    assert not missing.ok and missing.margin == -math.inf


def test_a_period_range_gets_the_physics_step_as_its_grid() -> None:
    # period_s must be a whole number of 2 ms physics steps: any other value is refused
    request = Request("line_circle", (f"{PERIOD}=0.01..0.1", f"{KP}=20..80", "seed=1,2,3"))
    period, kp, seed = make_axes(request, scenario_loader("line_circle", project=active_project()))
    assert (period.kind, period.step, period.nominal) == (AxisKind.GRID, 0.002, "0.01")
    assert (kp.kind, kp.integer, kp.nominal) == (AxisKind.GRID, True, "50")
    assert (seed.kind, seed.nominal) == (AxisKind.CHOICE, "1")


def _fake(points: list[Point], phase: Phase) -> list[Evaluation]:
    """line_circle as the issue describes it, without simulating: fails from 0.045 s up."""
    out = []
    for p in points:
        period = float(dict(p)[PERIOD])
        margin = (0.045 - period) / 0.045
        out.append(Evaluation(p, "", RunStatus.FAIL if margin < 0 else RunStatus.PASS, margin,
                              None, ("cross_track_max_m 0.009 (must be <= 0.008)",)
                              if margin < 0 else (), phase))
    return out


def test_the_found_scenario_file_holds_the_failing_values_and_loads_as_is(tmp_path: Path) -> None:
    request = Request("line_circle", (f"{PERIOD}=0.01..0.1",), ("duration_s=20",), budget=40)
    result = run_search(request, tmp_path, Options(tmp_path / "baselines",
                                                   active_project()), evaluate=_fake)
    assert result.exit_code == 1 and result.found_yaml == tmp_path / "found.yaml"
    spec = load_scenario(result.found_yaml, project=active_project())
    assert spec.agents["lt0"].controller.period_s == pytest.approx(0.046)
    assert spec.duration_s == 20  # the fixed overrides are written in too
    text = result.found_yaml.read_text(encoding="utf-8")
    assert f"boundary of {PERIOD}: 0.044 passes, 0.046 fails" in text
    page = result.page.read_text(encoding="utf-8")
    assert "<svg" in page and "0.046" in page and "http" not in page.split("<svg", 1)[0]


@pytest.mark.long(reason="six short simulations")
def test_an_interrupted_search_resumes_from_its_journal_and_runs_only_the_rest(
        tmp_path: Path) -> None:
    quick = ("duration_s=1", "criteria={}", "metrics.line_tracking.transient_s=0.5")
    opts = Options(tmp_path / "baselines", active_project())
    first = run_search(Request("line_circle", (f"{PERIOD}=0.01..0.1",), quick, budget=2),
                       tmp_path, opts)
    assert first.exit_code == 0 and len(first.found.counted) == 2
    again = run_search(Request("line_circle", (f"{PERIOD}=0.01..0.1",), quick, budget=4),
                       tmp_path, opts)
    assert again.resumed == 2 and len(again.found.counted) == 4
    assert [e.point for e in again.found.runs[:2]] == [e.point for e in first.found.runs]
    runs = json.loads((tmp_path / "search.json").read_text())["runs"]
    assert len(runs) == 4 and all(math.isinf(float(r["margin"])) for r in runs)


def test_a_search_interrupted_mid_way_resumes_to_the_same_result_running_only_the_rest(
        tmp_path: Path) -> None:
    request = Request("line_circle", (f"{PERIOD}=0.01..0.1",), budget=40, seed=5)
    whole = run_search(request, tmp_path / "whole", Options(tmp_path,
                                                            active_project()), evaluate=_fake)
    calls: list[list[Point]] = []

    def interrupted(points: list[Point], phase: Phase) -> list[Evaluation]:
        if len(calls) == 2:
            raise KeyboardInterrupt  # Ctrl-C in the third batch
        calls.append(points)
        return _fake(points, phase)

    with pytest.raises(KeyboardInterrupt):
        run_search(request, tmp_path / "cut", Options(tmp_path,
                                                      active_project()), evaluate=interrupted)
    ran: list[Point] = []

    def rest(points: list[Point], phase: Phase) -> list[Evaluation]:
        ran.extend(points)
        return _fake(points, phase)

    resumed = run_search(request, tmp_path / "cut", Options(tmp_path,
                                                            active_project()), evaluate=rest)
    assert [e.point for e in resumed.found.runs] == [e.point for e in whole.found.runs]
    assert resumed.found.failure == whole.found.failure
    before = [p for batch in calls for p in batch]
    assert resumed.resumed == len(before) and not set(ran) & set(before)
    assert len(ran) + len(before) == len(whole.found.runs)


def test_a_journal_of_other_settings_is_refused_not_overwritten(tmp_path: Path) -> None:
    run_search(Request("line_circle", (f"{PERIOD}=0.01..0.1",), budget=8), tmp_path,
               Options(tmp_path, active_project()), evaluate=_fake)
    with pytest.raises(Exception, match=r"holds a search with other settings \(seed\)"):
        run_search(Request("line_circle", (f"{PERIOD}=0.01..0.1",), budget=8, seed=1),
                   tmp_path, Options(tmp_path, active_project()), evaluate=_fake)


# The true boundary, from a sweep of every period the key takes (whole 2 ms physics steps) from
# 0.01 to 0.088 s (`kartci run line_circle --sweep ...`, 2026-11-29): 0.042 s passes
# (cross_track_max_m 0.00797 m), 0.044 s and every longer period fails.
SMALLEST_FAILING_S = 0.044


@pytest.mark.long(reason="a real 40-run search of line_circle (about 10 runs of 26 s sim)")
def test_the_line_tracker_search_finds_its_period_boundary_and_the_found_file_fails_again(
        tmp_path: Path) -> None:
    proc = kartci("search", "line_circle", "--over", f"{PERIOD}=0.01..0.1", "--budget", "40",
                  "--out", tmp_path / "out")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    found = tmp_path / "out" / "found.yaml"
    period = load_scenario(found, project=active_project()).agents["lt0"].controller.period_s
    assert abs(period - SMALLEST_FAILING_S) <= 0.005, proc.stdout
    assert "boundary of agents.lt0.controller.period_s: 0.042 passes, 0.044 fails" in proc.stdout
    again = kartci("run", found, "--out", tmp_path / "again")
    assert again.returncode == 1, again.stdout + again.stderr
    assert "cross_track_max_m" in again.stdout


def test_a_found_file_keeps_a_recorded_inputs_log_found_from_its_new_folder(
        tmp_path: Path) -> None:
    # kart_manual drives from logs/kart_manual_ps4.mcap, relative to scenarios/
    def run(points: list[Point], phase: Phase) -> list[Evaluation]:
        return [Evaluation(p, "", RunStatus.FAIL, -1.0, None, ("laps",), phase) for p in points]

    result = run_search(Request("kart_manual", ("duration_s=1..5",), budget=2), tmp_path / "o",
                        Options(tmp_path, active_project()), evaluate=run)
    assert result.found_yaml is not None
    spec = load_scenario(result.found_yaml, project=active_project())
    log = Path(spec.agents["kart0"].controller.source.log)  # type: ignore[attr-defined]
    assert log.is_file() and log.name == "kart_manual_ps4.mcap"
