"""`kartci.testing.check_kind` over every built-in (the contract test runs the checker a plugin
author runs): each registered robot kind, world kind, controller and metric set keeps its
contract, and the built-in scenarios that use them build, reset, step and score the same twice.
Faults get a message naming the part and what is wrong (Gymnasium's `check_env` pattern)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from kartci import core
from kartci.core import Direction, MetricDef, MetricSet, RobotKind
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.testing import (
    KindCheckError,
    check_controller,
    check_kind,
    check_metric_set,
    check_robot,
    check_world,
    parts_of,
)

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", core.ROBOTS.names())
def test_every_robot_kind_keeps_its_contract(name: str) -> None:
    assert check_robot(core.ROBOTS.get(name)).lines == [f"robot kind '{name}': contract"]


@pytest.mark.parametrize("name", core.WORLDS.names())
def test_every_world_kind_keeps_its_contract(name: str) -> None:
    check_world(core.WORLDS.get(name))


@pytest.mark.parametrize("name", core.CONTROLLERS.names())
def test_every_controller_keeps_its_contract(name: str) -> None:
    check_controller(core.CONTROLLERS.get(name))


@pytest.mark.parametrize("name", core.METRICS.names())
def test_every_metric_set_keeps_its_contract(name: str) -> None:
    check_metric_set(core.METRICS.get(name))


# every simulated built-in run by one of these, short: robot kinds, world kinds, controllers
# and metric sets (external needs a stack, commands a log: their contracts are checked above;
# the `recorded` parts of real-log import are not simulated)
RUNS = {
    "line_circle_edge_fast": (3.0, ["metrics.line_tracking.transient_s=0.5"]),
    "kart_manual": (1.0, []),
    "kart_simreal": (1.0, []),
    "kart_joy_driver": (1.0, []),
    "perception_obstacles": (1.5, []),
}


@pytest.mark.parametrize("scenario", sorted(RUNS))
def test_every_built_in_passes_check_kind(scenario: str) -> None:
    duration_s, overrides = RUNS[scenario]
    lines = check_kind(scenario, duration_s=duration_s, overrides=overrides).lines
    assert f"scenario '{scenario}': two runs score the same (wall-clock timings aside)" in lines


def test_the_runs_cover_every_simulated_built_in() -> None:
    used: dict[str, set[str]] = {"robot": set(), "world": set(), "controller": set(),
                                 "metrics": set()}
    for name in RUNS:
        for key, names in parts_of(load_scenario(name, project=active_project())).items():
            used[key] |= names
    not_simulated = {"recorded", "external", "commands", "bridge", "motion", "simreal"}
    assert set(core.ROBOTS.names()) - not_simulated <= used["robot"]
    assert set(core.WORLDS.names()) - not_simulated <= used["world"]
    assert set(core.CONTROLLERS.names()) - not_simulated <= used["controller"]
    assert set(core.METRICS.names()) - not_simulated <= used["metrics"]


def test_the_example_plugins_keep_their_contracts(monkeypatch: pytest.MonkeyPatch) -> None:
    """examples/pure_pursuit's driver and metric set (its own tests run check_kind on its
    scenario in a fresh venv: tests/examples/test_examples.py)."""
    monkeypatch.syspath_prepend(str(ROOT / "examples" / "pure_pursuit" / "src"))
    import kartci_pure_pursuit as example

    check_controller(example.CONTROLLER)
    check_metric_set(example.CORNERING)
    sys.modules.pop("kartci_pure_pursuit", None)


def test_a_fault_is_named_with_its_part() -> None:
    kart = core.ROBOTS.get("gokart")
    wrong = RobotKind("not_gokart", kart.params, kart.factory)
    with pytest.raises(KindCheckError, match=r"robot kind 'not_gokart': params GokartModel.kind "
                       r"is 'gokart', not the kind's name 'not_gokart'"):
        check_robot(wrong)
    vague = MetricSet("vague", {"x": MetricDef("", Direction.LOWER, 0.0, 0.0, "")},
                      lambda ctx, params: [])
    with pytest.raises(KindCheckError, match=r"metric set 'vague': metric 'x' needs a "
                       "MetricDef with a unit"):
        check_metric_set(vague)
    with pytest.raises(KindCheckError, match="does not use controller mpcc"):
        check_kind("kart_manual", controller="mpcc", duration_s=0.1)
