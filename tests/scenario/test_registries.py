"""A scenario is validated against the registries its caller hands over (pydantic's validation
context), not against module globals its validators reach for."""

from __future__ import annotations

import dataclasses
import json

import pytest

from kartci import core
from kartci.errors import SpecError
from kartci.project import BUILTIN_MODELS
from kartci.project import current as active_project
from kartci.scenario import Scenario, load_scenario, scenario_from_json
from kartci.scenario.dispatch import context
from kartci.scenario.schema import scenario_schema


def _without(registry: core.Registry[core.RobotKind], name: str) -> core.Registry[core.RobotKind]:
    items = {r.name: r for r in registry.all() if r.name != name}
    return core.Registry(registry.group, registry.what, registry.kind, items)


def test_a_registry_without_a_kind_reports_it_unknown_and_the_global_one_is_untouched() -> None:
    before = core.ROBOTS.names()
    assert "line_tracker" in before
    fewer = dataclasses.replace(core.DEFAULT_REGISTRIES,
                                robots=_without(core.ROBOTS, "line_tracker"))

    with pytest.raises(SpecError) as err:
        load_scenario("line_straight", registries=fewer, project=active_project())
    known = ", ".join(n for n in before if n != "line_tracker")
    # named where the model file says it: line 2 of the line tracker's params.yaml
    assert str(err.value) == (f"{BUILTIN_MODELS / 'line_tracker' / 'params.yaml'}:2:1: kind: "
                              f"unknown robot kind 'line_tracker' (known: {known})")

    assert core.ROBOTS.names() == before
    assert load_scenario("line_straight",
                         project=active_project()).agents["lt0"].model.kind == "line_tracker"
    spec = load_scenario("line_straight", project=active_project()).model_dump_json()
    with pytest.raises(SpecError, match="unknown robot kind 'line_tracker'"):
        scenario_from_json(spec, registries=fewer)
    schema = json.dumps(scenario_schema(fewer))
    assert "robot kind `line_tracker`" not in schema
    assert "robot kind `line_tracker`" in json.dumps(scenario_schema())


def test_a_scenario_validated_without_registries_is_a_callers_bug_named_as_such() -> None:
    data = json.loads(load_scenario("line_straight", project=active_project()).model_dump_json())
    with pytest.raises(TypeError, match="registries in its validation context"):
        Scenario.model_validate(data)
    again = Scenario.model_validate(data, context=context(core.DEFAULT_REGISTRIES))
    assert again == load_scenario("line_straight", project=active_project())
