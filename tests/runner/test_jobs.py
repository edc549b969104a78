"""Which runs a `kartci run` makes: a scenario's own sweep (a grid), `--sweep` instead of it,
and grids kept out of the default suite."""

from __future__ import annotations

from kartci.project import BUILTIN_SCENARIOS
from kartci.project import current as active_project
from kartci.runner import expand
from kartci.runner.jobs import default_suite


def test_a_grid_scenario_expands_into_its_points_each_with_its_label() -> None:
    jobs = expand(["line_circle_grid"], [], active_project())
    assert len(jobs) == 6 * 5
    labels = {j.label for j in jobs}
    assert ("line_circle_grid@agents.lt0.controller.period_s=0.04,world.course.radius_m=0.45"
            in labels)
    job = next(j for j in jobs if j.label.endswith("period_s=0.1,world.course.radius_m=0.5"))
    assert job.spec.agents["lt0"].controller.period_s == 0.1
    assert job.spec.world.course.radius_m == 0.5  # type: ignore[attr-defined]


def test_sweep_on_the_command_line_replaces_the_scenarios_own() -> None:
    jobs = expand(["line_circle_grid"], [],
                  active_project(), ["agents.lt0.controller.period_s=0.02"])
    assert [j.label for j in jobs] == ["line_circle_grid@agents.lt0.controller.period_s=0.02"]


def test_the_default_suite_leaves_the_grids_out() -> None:
    """The default suite stays fast: `kartci run` with no names skips every scenario with a
    sweep (and `tool` ones); they run by name."""
    suite = default_suite(sorted(BUILTIN_SCENARIOS.glob("*.yaml")), active_project())
    assert "line_circle" in suite and "line_circle_pi" in suite
    assert not [n for n in suite if n.endswith("_grid") or n.startswith("line_circle_edge")]
