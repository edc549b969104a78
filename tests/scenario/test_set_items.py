"""`--set` on list items (`world.zones.0.friction=0.3`): validated as if the file held the
value, its errors one line, exit 2, naming the file and line of what the file gave and echoing
only what was typed."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import kartci

from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.scenario import load_scenario

ZONE = "{name: wet, min_m: [0.0, 0.0], max_m: [8.0, 20.0], friction: -0.5}"


def test_a_list_items_field_a_nested_item_and_a_whole_item_are_set() -> None:
    spec = load_scenario("obstacle_avoidance", [
        "world.zones.0.friction=0.3", "world.obstacles.1.center_m.0=30.0",
        "world.obstacles.4={center_m: [5.0, 4.0], size_m: [1.0, 1.0, 1.0]}",
        "agents.kart0.model.steering_limit_rad.1=0.5"], project=active_project())
    world = spec.world
    assert world.zones[0].friction == 0.3  # type: ignore[attr-defined]
    assert world.obstacles[1].center_m == (30.0, 5.94)  # type: ignore[attr-defined]
    assert world.obstacles[4].size_m == (1.0, 1.0, 1.0)  # type: ignore[attr-defined]
    assert spec.agents["kart0"].model.steering_limit_rad == (-1.845, 0.5)  # type: ignore[attr-defined]
    # the scenario file is untouched by the next load
    again = load_scenario("obstacle_avoidance", project=active_project())
    assert again.world.zones[0].friction == 0.6  # type: ignore[attr-defined]


@pytest.mark.parametrize(("assignment", "message"), [
    ("world.zones.3.friction=0.3",
     "--set world.zones.3.friction: 'world.zones' has 1 item (index 0 to 0): there is no item 3"),
    ("world.zones.x.friction=0.3",
     "--set world.zones.x.friction: 'world.zones' is a list: 'x' is not an item index "
     "(index 0 to 0)"),
    ("world.zones.-1.friction=0.3",
     "--set world.zones.-1.friction: 'world.zones' is a list: '-1' is not an item index "
     "(index 0 to 0)"),
    ("agents.kart0.model.wheel_xy_m.0.1=0.6",
     "--set agents.kart0.model.wheel_xy_m.0.1: 'agents.kart0.model.wheel_xy_m' is not in the "
     "scenario or its files (its default applies), so there is no item 0 to set (give the "
     "whole list: --set agents.kart0.model.wheel_xy_m=[...])"),
    ("world.floor_friction.0=1",
     "--set world.floor_friction.0: 'world.floor_friction' is not a mapping or a list"),
])
def test_an_item_that_is_not_there_is_one_line(assignment: str, message: str) -> None:
    with pytest.raises(SpecError) as err:
        load_scenario("mpcc_lap", [assignment], project=active_project())
    assert str(err.value) == message
    p = kartci("show", "mpcc_lap", "--set", assignment)
    assert (p.returncode, p.stdout, p.stderr) == (2, "", f"kartci: error: {message}\n")


def test_a_bad_item_value_is_judged_as_in_a_file(tmp_path: Path) -> None:
    """A bad value the file gave is named by its file, line and column and never echoed,
    whatever else of that item was set; a value typed is echoed, marked (from --set)."""
    scenario = tmp_path / "wet.yaml"
    text = ("description: a wet zone\nduration_s: 1.0\nworld:\n  from: winti/hall\n  zones:\n"
            f"    - {ZONE}\nagents:\n  kart0:\n    model: gokart\n"
            "    controller: {type: mpcc}\n")
    scenario.write_text(text, encoding="utf-8")
    column = text.splitlines()[5].index("friction") + 1
    in_file = f"{scenario}:6:{column}: world.zones.0.friction: must be at least 0"
    typed = f"{scenario}: world.zones.0.friction (from --set): must be at least 0 (got -2)"
    for sets, message in ((["world.zones.0.name=dry"], in_file),
                          (["world.zones.0.friction=-2"], typed),
                          (["world.zones=[{name: a, min_m: [0, 0], max_m: [1, 1], friction: -2}]"],
                           typed)):
        with pytest.raises(SpecError) as err:
            load_scenario(scenario, sets, project=active_project())
        assert str(err.value) == message
    p = kartci("show", scenario, "--set", "world.zones.0.name=dry")
    assert (p.returncode, p.stdout, p.stderr) == (2, "", f"kartci: error: {in_file}\n")
    fixed = load_scenario(scenario, ["world.zones.0.friction=0.3", "world.zones.0.name=dry"],
                          project=active_project())
    assert (fixed.world.zones[0].name, fixed.world.zones[0].friction) == (  # type: ignore[attr-defined]
        "dry", 0.3)


def test_an_unknown_field_of_an_item_is_named_with_the_nearest_one() -> None:
    with pytest.raises(SpecError, match=r"mpcc_lap.yaml: world\.zones\.0\.frictio \(from --set\): "
                       r"unknown key \(did you mean 'friction'\?\)$"):
        load_scenario("mpcc_lap", ["world.zones.0.frictio=0.3"], project=active_project())
