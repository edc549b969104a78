"""Issue 44: the search and the shrinker on a synthetic space whose failure region is known, with
a fake runner injected (no simulation): it finds the region and shrinks to its boundary."""

from __future__ import annotations

import math

from kartci.runner.search import (
    RESOLUTION,
    Axis,
    AxisKind,
    Evaluation,
    Phase,
    Plan,
    Point,
    RunStatus,
    search,
)

# The failure region: a corner, x > 0.6 and y > 0.5, with the nominal (0.1, 0.1) outside it.
# The failure nearest the nominal is the corner itself, (0.6, 0.5).
X0, Y0 = 0.6, 0.5
TOL = 1.0 / RESOLUTION  # a continuous axis of span 1 is bracketed to span / RESOLUTION
AXES = (Axis("a.x", AxisKind.FLOAT, "0.1", 0.0, 1.0), Axis("a.y", AxisKind.FLOAT, "0.1", 0.0, 1.0))


class Fake:
    """A runner that knows the region: the margin is the distance into it (negative inside)."""

    def __init__(self) -> None:
        self.batches: list[list[Point]] = []

    def __call__(self, points: list[Point], phase: Phase) -> list[Evaluation]:
        self.batches.append(points)
        out = []
        for p in points:
            x, y = (float(v) for _, v in p)
            margin = max(X0 - x, Y0 - y)  # >= 0 outside the corner: passes
            status = RunStatus.FAIL if margin < 0 else RunStatus.PASS
            out.append(Evaluation(p, f"s@{x},{y}", status, margin, None,
                                  ("in the corner",) if margin < 0 else (), phase))
        return out


def test_a_search_over_two_axes_finds_the_failure_region_and_shrinks_to_its_corner() -> None:
    fake = Fake()
    found = search(Plan(AXES, budget=60, seed=3), fake)
    assert found.failure is not None and found.failure.status is RunStatus.FAIL
    x, y = (float(v) for _, v in found.failure.point)
    # the nearest failure to the nominal, within the stated tolerance of the corner
    assert X0 < x <= X0 + TOL and Y0 < y <= Y0 + TOL
    brackets = {b.key: b for b in found.brackets}
    assert float(brackets["a.x"].passing) <= X0 < float(brackets["a.x"].failing)
    assert float(brackets["a.y"].passing) <= Y0 < float(brackets["a.y"].failing)
    assert len(found.counted) <= 60 and found.shrunk
    assert fake.batches[0][0] == (("a.x", "0.1"), ("a.y", "0.1"))  # the nominal first


def test_the_same_seed_gives_the_same_search_and_another_seed_another() -> None:
    one, two, other = (search(Plan(AXES, budget=40, seed=s), Fake()) for s in (7, 7, 8))
    assert [e.point for e in one.runs] == [e.point for e in two.runs]
    assert [e.point for e in one.runs] != [e.point for e in other.runs]


def test_a_space_without_failures_spends_the_budget_and_reports_the_smallest_margin() -> None:
    axes = (Axis("a.x", AxisKind.FLOAT, "0.1", 0.0, 0.5), AXES[1])
    found = search(Plan(axes, budget=12, seed=0), Fake())
    assert found.failure is None and len(found.counted) == 12
    small = found.smallest
    assert small is not None and small.margin == min(e.margin for e in found.runs)
    assert 0 < found.coverage <= 12 / 100  # 10 x 10 cells, at most one new cell per run


def test_a_grid_axis_shrinks_to_neighbouring_grid_values() -> None:
    # a period in whole 2 ms steps failing from 0.045 s up: the boundary is 0.044 | 0.046
    axis = Axis("c.period_s", AxisKind.GRID, "0.01", 0.01, 0.1, step=0.002)

    def run(points: list[Point], phase: Phase) -> list[Evaluation]:
        return [Evaluation(p, "", RunStatus.FAIL if float(p[0][1]) > 0.045 else RunStatus.PASS,
                           0.045 - float(p[0][1]), None, (), phase) for p in points]

    found = search(Plan((axis,), budget=40, seed=0), run)
    assert found.failure is not None and found.failure.point == (("c.period_s", "0.046"),)
    assert [(b.passing, b.failing) for b in found.brackets] == [("0.044", "0.046")]


def test_a_failing_nominal_is_the_failure_reported() -> None:
    def run(points: list[Point], phase: Phase) -> list[Evaluation]:
        return [Evaluation(p, "", RunStatus.FAIL, -1.0, None, ("always",), phase) for p in points]

    found = search(Plan(AXES, budget=10), run)
    assert found.failure is not None and found.failure.point == (("a.x", "0.1"), ("a.y", "0.1"))
    assert found.brackets == ()


def test_an_objective_search_reports_the_worst_value_over_the_budget() -> None:
    def run(points: list[Point], phase: Phase) -> list[Evaluation]:
        return [Evaluation(p, "", RunStatus.PASS, 1.0, -(float(p[0][1]) - 0.7) ** 2, (), phase)
                for p in points]

    found = search(Plan(AXES, budget=30, seed=1, objective="m", higher_is_worse=False), run)
    assert len(found.counted) == 30 and found.worst is found.failure
    assert found.failure is not None
    assert found.failure.value == min(e.value for e in found.runs if e.value is not None)
    assert not math.isnan(found.failure.margin)


def test_the_budget_bounds_the_shrinking_too() -> None:
    fake = Fake()
    found = search(Plan(AXES, budget=6, seed=3), fake)
    assert len(found.counted) <= 6
    assert found.failure is not None and not found.shrunk  # and it says so


def test_a_choice_axis_moves_to_the_scenarios_own_choice_when_that_still_fails() -> None:
    axes = (Axis("a.mode", AxisKind.CHOICE, "geometric", choices=("geometric", "rendered")),
            AXES[0])

    def run(points: list[Point], phase: Phase) -> list[Evaluation]:
        return [Evaluation(p, "", RunStatus.FAIL if float(p[1][1]) > 0.6 else RunStatus.PASS,
                           0.6 - float(p[1][1]), None, (), phase) for p in points]

    found = search(Plan(axes, budget=40, seed=2), run)
    assert found.failure is not None and found.failure.point[0] == ("a.mode", "geometric")
    assert X0 < float(found.failure.point[1][1]) <= X0 + TOL


def test_a_finite_space_spends_the_whole_budget_though_the_sampler_repeats_its_best() -> None:
    # 46 periods, the metric as line_circle's cross_track_max_m: rising, then a plateau where
    # the line is lost (from 0.076 s), on which TPE keeps proposing points it has seen
    axis = Axis("c.period_s", AxisKind.GRID, "0.01", 0.01, 0.1, step=0.002)

    def run(points: list[Point], phase: Phase) -> list[Evaluation]:
        out = []
        for p in points:
            t = float(p[0][1])
            value = 0.0208 + 1e-5 * math.sin(1e3 * t) if t > 0.075 else 0.0076 + (
                max(0.0, t - 0.036) ** 2)
            out.append(Evaluation(p, "", RunStatus.PASS, 1.0, value, (), phase))
        return out

    found = search(Plan((axis,), budget=40, seed=0, objective="m"), run)
    assert len(found.counted) == 40 == len({e.point for e in found.runs})
    assert found.failure is not None and float(found.failure.point[0][1]) > 0.075
