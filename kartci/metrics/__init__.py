"""Metrics: functions from a run log to named numbers with units. Never touches the simulator."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from kartci.errors import LogError
from kartci.logs import tables
from kartci.metrics.base import DEFS, Direction, Metric, MetricDef
from kartci.metrics.line import line_metrics, sensor_track
from kartci.spec import Scenario, scenario_from_json


def recorded_scenario(log_tables: Mapping[str, Any], path: Path) -> Scenario:
    table = log_tables.get("/kartci/scenario")
    if table is None or getattr(table, "empty", True):
        raise LogError(f"{path}: no /kartci/scenario message; not a kartci run log")
    return scenario_from_json(str(table["data"].iloc[0]))


def compute(log_path: Path) -> tuple[Scenario, dict[str, Metric]]:
    """All metrics of a run log, keyed by name (single agent) or `agent.name` (several)."""
    log_tables = tables(log_path)
    scenario = recorded_scenario(log_tables, log_path)
    out: dict[str, Metric] = {}
    many = len(scenario.agents) > 1
    for agent in scenario.agents:
        odom = log_tables.get(f"/{agent}/odom")
        if odom is None:
            raise LogError(f"{log_path}: no /{agent}/odom topic")
        for m in line_metrics(scenario, agent, odom):
            out[f"{agent}.{m.name}" if many else m.name] = m
    return scenario, out


__all__ = ["DEFS", "Direction", "Metric", "MetricDef", "compute", "line_metrics",
           "recorded_scenario", "sensor_track"]
