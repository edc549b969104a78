"""Scenario specs: typed models, loading, `--set` overrides, JSON Schema."""

from kartci.spec.load import (
    ScenarioEntry,
    json_schema,
    load_scenario,
    project_root,
    scenario_catalogue,
    scenario_from_json,
    scenario_names,
)
from kartci.spec.models import (
    AgentSpec,
    CircleCourse,
    Criterion,
    LineLabWorld,
    LinePidController,
    LineSensorSpec,
    LineTrackerModel,
    Scenario,
    StraightCourse,
)

__all__ = [
    "AgentSpec",
    "CircleCourse",
    "Criterion",
    "LineLabWorld",
    "LinePidController",
    "LineSensorSpec",
    "LineTrackerModel",
    "Scenario",
    "ScenarioEntry",
    "StraightCourse",
    "json_schema",
    "load_scenario",
    "project_root",
    "scenario_catalogue",
    "scenario_from_json",
    "scenario_names",
]
