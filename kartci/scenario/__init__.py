"""Scenario specs: typed models, loading, `--set` overrides, JSON Schema."""

from kartci.scenario.load import (
    ScenarioEntry,
    json_schema,
    load_scenario,
    project_root,
    scenario_catalogue,
    scenario_from_json,
    scenario_names,
    with_overrides,
)
from kartci.scenario.models import (
    AgentSpec,
    CircleCourse,
    Criterion,
    LineLabWorld,
    Scenario,
    StraightCourse,
)

__all__ = [
    "AgentSpec",
    "CircleCourse",
    "Criterion",
    "LineLabWorld",
    "Scenario",
    "ScenarioEntry",
    "StraightCourse",
    "json_schema",
    "load_scenario",
    "project_root",
    "scenario_catalogue",
    "scenario_from_json",
    "scenario_names",
    "with_overrides",
]
