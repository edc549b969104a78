"""Nodes (`agents.<name>.nodes`): registered like controllers, validated per node type, run in
the robot's namespace before its controller at the same tick."""

from __future__ import annotations

from typing import Any

import pytest
from helpers import kartci

from kartci import core
from kartci.core import AgentContext, Node, NodeParams
from kartci.errors import SpecError
from kartci.logs import msg
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.sim.session import Session


class CountParams(NodeParams):
    start: int = 0


class Counter:
    """Publishes its tick count on `probe` (in the robot's namespace)."""

    inputs: tuple[str, ...] = ()

    def __init__(self, params: CountParams, ctx: AgentContext) -> None:
        self.period_s, self.n, self.ns = params.period_s, params.start, ctx.name

    def on_message(self, topic: str, message: Any) -> None:
        pass

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        self.n += 1
        return [("probe", msg("std_msgs/msg/String", data=f"{t_ns} {self.n}"))]


class Reader:
    """A controller that remembers which node message it had at each of its ticks."""

    period_s = 0.06
    inputs = ("probe",)

    def __init__(self) -> None:
        self.last = ""
        self.seen: list[tuple[int, str]] = []

    def on_message(self, topic: str, message: Any) -> None:
        self.last = message.data

    def step(self, t_ns: int) -> list[tuple[str, Any]]:
        self.seen.append((t_ns, self.last))
        return []


@pytest.fixture()
def counter() -> Any:
    core.register(Node("test_counter", CountParams, Counter, (), "counts ticks"))
    yield
    core.NODES.items.pop("test_counter")


def test_a_node_runs_before_the_controller_of_its_robot(counter: Any) -> None:
    """Node every 0.02 s, controller every 0.06 s: at each controller tick the node's message
    of that very tick is already there, and the node ran 3 times per controller tick."""
    spec = load_scenario("line_straight", ["duration_s=0.5",
                                           "agents.lt0.nodes={test_counter: {start: 100}}"],
                                           project=active_project())
    reader = Reader()
    with Session(spec, agents={"lt0": reader}) as s:
        r = s.reset()
        topics = {t for t, _ in r.messages}
        while not r.done:
            r = s.step()
    assert "/lt0/probe" in topics
    assert len(reader.seen) == 9  # t = 0, 0.06, ..., 0.48
    for i, (t_ns, last) in enumerate(reader.seen):
        assert last == f"{t_ns} {101 + 3 * i}"


def test_node_names_and_parameters_are_validated(counter: Any) -> None:
    with pytest.raises(SpecError, match=r"agents\.lt0\.nodes\.test_countr( \(from --set\))?: "
                                        r"unknown node 'test_countr'.*test_counter"):
        load_scenario("line_straight", ["agents.lt0.nodes={test_countr: {}}"],
                      project=active_project())
    with pytest.raises(SpecError, match=r"agents\.lt0\.nodes\.test_counter\.start"):
        load_scenario("line_straight", ["agents.lt0.nodes={test_counter: {start: many}}"],
                      project=active_project())
    with pytest.raises(SpecError, match=r"nodes\.test_counter\.period_s.*not a whole multiple"):
        load_scenario("line_straight", ["agents.lt0.nodes={test_counter: {period_s: 0.0033}}"],
                      project=active_project())


def test_a_node_for_another_robot_kind_is_refused() -> None:
    spec = load_scenario("line_straight", ["agents.lt0.nodes={localization: {}}"],
                         project=active_project())
    with pytest.raises(SpecError, match="node localization runs on gokart robots, not "
                                        "line_tracker"), Session(spec) as s:
        s.reset()


def test_cli_lists_nodes_and_names_a_bad_one_in_one_line() -> None:
    assert ("node", "localization") in {(p.kind, p.name) for p in core.catalogue()}
    bad = kartci("show", "localization_lap", "--set",
                 "agents.kart0.nodes={localisation: {}}")
    assert bad.returncode == 2
    assert "unknown node 'localisation'" in bad.stderr and "Traceback" not in bad.stderr
