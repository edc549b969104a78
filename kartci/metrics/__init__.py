"""Metrics: functions from a run log to named numbers with units. Never touches the simulator.

Which metric sets run for an agent: its robot kind's own sets, then those the scenario names
under `metrics:`; each set is a registered `MetricSet` (see `kartci.core`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from kartci import core
from kartci.core import (
    Direction,
    Metric,
    MetricDef,
    MetricParams,
    Outline,
    definition,
    definitions,
)
from kartci.errors import LogError
from kartci.logs import SCENARIO_TOPIC, tables
from kartci.scenario import Scenario, scenario_from_json

if TYPE_CHECKING:  # pandas, the log readers and scipy load when a log is scored, not before
    import pandas as pd

    from kartci.worlds.track import Track

T = TypeVar("T")


@dataclass
class ScoreContext:
    """One agent's view of a run log, and a cache shared by all agents of that log (so a
    derived table, say every kart's path along the track, is computed once)."""

    scenario: Scenario
    tables: Mapping[str, pd.DataFrame]
    path: Path
    agent: str
    cache: dict[str, Any] = field(default_factory=dict)

    def table(self, topic: str) -> pd.DataFrame | None:
        """A topic's table (relative topics are in the agent's namespace), or None."""
        full = topic if topic.startswith("/") else f"/{self.agent}/{topic}"
        return self.tables.get(full)

    @property
    def odom(self) -> pd.DataFrame:
        """The agent's odometry table; a LogError when the log has none."""
        odom = self.table("odom")
        if odom is None or odom.empty:
            raise LogError(f"{self.path}: no /{self.agent}/odom messages")
        return odom

    def shared(self, key: str, make: Callable[[], T]) -> T:
        """`make()` computed once per log and shared by all its agents, under `key`."""
        if key not in self.cache:
            self.cache[key] = make()
        value: T = self.cache[key]
        return value

    def params(self, mset: core.MetricSet) -> Any:
        """The set's parameters from the scenario, else its defaults."""
        given = self.scenario.metrics.get(mset.name)
        if given is not None:
            return given
        return mset.params() if mset.params is not None else MetricParams()


def metric_sets(scenario: Scenario, agent: str) -> list[core.MetricSet]:
    """The sets computed for one agent: its robot kind's, then the scenario's, once each."""
    kind = scenario.agents[agent].model.kind
    names = [*core.ROBOTS.get(kind).metrics, *scenario.metrics]
    sets = [core.METRICS.get(n) for n in dict.fromkeys(names)]
    return [s for s in sets if not s.robots or kind in s.robots]


def outline_of(ctx: ScoreContext, agent: str) -> Outline | None:
    """An agent's outline (convex parts in base_link, m) as its robot kind derives it from the
    robot's description the log recorded (`/<agent>/robot_description`; a log without one: the
    model's file), once per log; None: the kind declares no outline (a point at base_link)."""
    def make() -> Outline | None:
        model = ctx.scenario.agents[agent].model
        kind = core.ROBOTS.get(model.kind)
        if kind.outline is None:
            return None
        table = ctx.tables.get(f"/{agent}/robot_description")
        text = None if table is None or table.empty else str(table["data"].iloc[0])
        return kind.outline(model, text)

    return ctx.shared(f"outline /{agent}", make)


def recorded_scenario(log_tables: Mapping[str, Any], path: Path) -> Scenario:
    """The scenario a run log recorded on /kartci/scenario: the one its metrics are scored with."""
    table = log_tables.get(SCENARIO_TOPIC)
    if table is None or getattr(table, "empty", True):
        raise LogError(f"{path}: no {SCENARIO_TOPIC} message; not a kartci run log")
    return scenario_from_json(str(table["data"].iloc[0]))


def recorded_track(log_tables: Mapping[str, Any], path: Path) -> Track:
    """The track a run log recorded on /kartci/track, so laps are scored from the log alone."""
    # start-up: kartci.worlds.track brings scipy (+0.3 s), needed once a log's laps are scored
    from kartci.worlds.track import TRACK_TOPIC, track_from_text

    table = log_tables.get(TRACK_TOPIC)
    if table is None or getattr(table, "empty", True):
        raise LogError(f"{path}: no {TRACK_TOPIC} message; cannot score laps")
    return track_from_text(str(table["data"].iloc[0]), "recorded track")


def compute(log_path: Path) -> tuple[Scenario, dict[str, Metric]]:
    """All metrics of a run log, keyed by name (single agent) or `agent.name` (several)."""
    log_tables = tables(log_path)
    scenario = recorded_scenario(log_tables, log_path)
    many = len(scenario.agents) > 1
    cache: dict[str, Any] = {}
    contexts = [ScoreContext(scenario, log_tables, log_path, a, cache) for a in scenario.agents]
    for ctx in contexts:
        ctx.odom  # noqa: B018  (every agent must have odometry: fail before scoring any)
    out: dict[str, Metric] = {}
    for ctx in contexts:
        for mset in metric_sets(scenario, ctx.agent):
            for m in mset.compute(ctx, ctx.params(mset)):
                out[f"{ctx.agent}.{m.name}" if many else m.name] = m
    return scenario, out


__all__ = ["Direction", "Metric", "MetricDef", "ScoreContext", "compute", "definition",
           "definitions", "metric_sets", "outline_of", "recorded_scenario", "recorded_track"]
