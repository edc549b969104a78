from __future__ import annotations

from pathlib import Path

import pytest

from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.robots.line_tracker.controllers import LinePidController
from kartci.scenario import json_schema, load_scenario, scenario_names


@pytest.mark.parametrize("name", scenario_names(active_project()))
def test_every_scenario_validates(name: str) -> None:
    spec = load_scenario(name, project=active_project())
    assert spec.name == name
    assert spec.description
    assert spec.agents


def test_set_overrides_any_value() -> None:
    spec = load_scenario("line_circle", ["agents.lt0.controller.period_s=0.06",
                                         "agents.lt0.controller.kp=20", "seed=7",
                                         "world.course.radius_m=0.8"], project=active_project())
    ctrl = spec.agents["lt0"].controller
    assert isinstance(ctrl, LinePidController)
    assert (ctrl.period_s, ctrl.kp, spec.seed) == (0.06, 20.0, 7)
    assert spec.world.course.radius_m == 0.8  # type: ignore[attr-defined]


def test_unknown_set_key_names_the_key() -> None:
    with pytest.raises(SpecError, match=r"agents\.lt0\.controller\.kpp.*unknown key"):
        load_scenario("line_straight", ["agents.lt0.controller.kpp=3"], project=active_project())


def test_bad_value_names_key_and_expectation() -> None:
    with pytest.raises(SpecError, match=r"controller\.kp \(from --set\): Input should be a "
                                        r"valid number.*\"fast\""):
        load_scenario("line_straight", ["agents.lt0.controller.kp=fast"], project=active_project())


def test_period_must_be_a_multiple_of_the_physics_step() -> None:
    with pytest.raises(SpecError, match=r"not a whole multiple of physics\.dt_s"):
        load_scenario("line_straight", ["agents.lt0.controller.period_s=0.0031"],
                      project=active_project())


def test_missing_scenario_lists_known_ones() -> None:
    with pytest.raises(SpecError, match=r"unknown scenario 'nope'.*line_straight"):
        load_scenario("nope", project=active_project())


def test_malformed_yaml_names_file_and_line(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("description: x\nagents: [unclosed\n")
    with pytest.raises(SpecError, match=r"bad\.yaml:\d+:\d+: "):
        load_scenario(str(bad), project=active_project())


def test_missing_required_key(tmp_path: Path) -> None:
    bad = tmp_path / "nodur.yaml"
    bad.write_text("description: x\nworld: line_lab/straight\nagents:\n  lt0:\n"
                   "    model: line_tracker\n    controller: {type: line_pid}\n")
    with pytest.raises(SpecError, match=r"nodur\.yaml: duration_s: required key is missing"):
        load_scenario(str(bad), project=active_project())


def test_schema_describes_scenarios() -> None:
    schema = json_schema()
    assert {"world", "agents", "duration_s", "seed"} <= set(schema["properties"])
    assert "anyOf" in schema["properties"]["world"]


def test_a_model_from_a_folder_with_keys_replaced() -> None:
    """`model: {from: line_tracker, KEY: value}` reads the folder's parameters, then replaces."""
    spec = load_scenario("line_straight_grid", project=active_project())
    model = spec.agents["lt0"].model
    assert model.wheel_time_constant_s == 0.0  # type: ignore[attr-defined]
    assert model.wheel_radius_m == 0.035  # type: ignore[attr-defined]  # from params.yaml
    assert Path(model.urdf).is_file()


def test_a_model_from_an_unknown_folder_names_it(tmp_path: Path) -> None:
    f = tmp_path / "s.yaml"
    f.write_text("description: x\nworld: line_lab/straight\nduration_s: 1\nagents:\n  a:\n"
                 "    model: {from: no_such_robot, wheel_radius_m: 0.1}\n"
                 "    controller: {type: line_pid}\n")
    with pytest.raises(SpecError, match="no_such_robot"):
        load_scenario(f, project=active_project())
