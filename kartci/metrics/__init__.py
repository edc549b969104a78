"""Metrics: functions from a run log to named numbers with units. Never touches the simulator."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from kartci.errors import LogError
from kartci.logs import tables
from kartci.metrics import race
from kartci.metrics.base import DEFS, Direction, Metric, MetricDef
from kartci.metrics.kart import kart_metrics, kart_track
from kartci.metrics.line import line_metrics, sensor_track
from kartci.spec import Scenario, scenario_from_json
from kartci.spec.models import HallWorld
from kartci.track import Track, track_from_text


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
    track = recorded_track(log_tables, log_path) if isinstance(scenario.world, HallWorld) else None
    odoms = {}
    for agent in scenario.agents:
        odom = log_tables.get(f"/{agent}/odom")
        if odom is None or odom.empty:
            raise LogError(f"{log_path}: no /{agent}/odom messages")
        odoms[agent] = odom
    # each kart's path along the track and footprints, once: every agent's metrics use them
    paths = {a: kart_track(track, o) for a, o in odoms.items()} if track is not None else {}
    rects = {a: race.kart_rects(o) for a, o in odoms.items()} if track is not None else {}
    for agent, odom in odoms.items():
        if track is None:
            values = line_metrics(scenario, agent, odom)
        else:
            values = kart_metrics(scenario, agent, track, paths[agent],
                                  log_tables.get(f"/{agent}/collision"))
            values += race_metrics(scenario, agent, paths, rects,
                                   log_tables.get(f"/{agent}/mpcc/stats"))
        for m in values:
            out[f"{agent}.{m.name}" if many else m.name] = m
    return scenario, out


def race_metrics(scenario: Scenario, agent: str, paths: Mapping[str, pd.DataFrame],
                 rects: Mapping[str, list[race.Rect]],
                 stats: pd.DataFrame | None) -> list[Metric]:
    """Clearance, overtakes and solver statistics, where the run has what they need."""
    world = scenario.world
    assert isinstance(world, HallWorld)
    others = [n for n in paths if n != agent]
    out = []
    if world.obstacles or others:
        gap = race.min_clearance_m(rects[agent], world.obstacles, [rects[n] for n in others])
        out.append(Metric("min_clearance_m", gap, "m"))
    if others:
        theirs = [paths[n]["s_total"].to_numpy() for n in others]
        out.append(Metric("overtakes", float(race.overtakes(paths[agent]["s_total"].to_numpy(),
                                                            theirs)), "count"))
    if stats is not None and not stats.empty:
        failures, timing = race.solver_values(stats)
        out.append(Metric("solver_failures", float(failures), "count"))
        out += [Metric(name, value, "ms") for name, value in timing.items()]
    return out


def recorded_track(log_tables: Mapping[str, Any], path: Path) -> Track:
    table = log_tables.get("/kartci/track")
    if table is None or getattr(table, "empty", True):
        raise LogError(f"{path}: no /kartci/track message; cannot score laps")
    return track_from_text(str(table["data"].iloc[0]), "recorded track")


__all__ = ["DEFS", "Direction", "Metric", "MetricDef", "compute", "kart_metrics", "kart_track",
           "line_metrics", "recorded_scenario", "recorded_track", "sensor_track"]
