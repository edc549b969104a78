"""Scenario specs: typed models, loading, `--set` overrides, JSON Schema."""

from kartci.scenario.load import (
    ScenarioEntry,
    in_project,
    json_schema,
    load_scenario,
    scenario_catalogue,
    scenario_from_json,
    scenario_names,
    with_overrides,
)
from kartci.scenario.models import AgentSpec, Criterion, Scenario

__all__ = [
    "AgentSpec",
    "Criterion",
    "Scenario",
    "ScenarioEntry",
    "in_project",
    "json_schema",
    "load_scenario",
    "scenario_catalogue",
    "scenario_from_json",
    "scenario_names",
    "with_overrides",
]
