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
from kartci.scenario.models import AgentSpec, Criterion, Scenario

__all__ = [
    "AgentSpec",
    "Criterion",
    "Scenario",
    "ScenarioEntry",
    "json_schema",
    "load_scenario",
    "project_root",
    "scenario_catalogue",
    "scenario_from_json",
    "scenario_names",
    "with_overrides",
]
