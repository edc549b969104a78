"""Registries: every registered plugin keeps the contract (HighwayEnv's pattern: one test
parametrised over everything registered), and every shipped scenario still scores exactly as
its committed baseline."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest
from pydantic import BaseModel

from kartci import core
from kartci.core import Controller, MetricDef, MetricSet
from kartci.errors import SpecError
from kartci.metrics import compute, definitions
from kartci.project import BUILTIN_SCENARIOS
from kartci.project import current as active_project
from kartci.scenario import load_scenario
from kartci.scenario.models import ControllerParams
from kartci.sim import simulate
from kartci.verdict import check_criteria

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", core.CONTROLLERS.names())
def test_every_controller_has_typed_parameters_with_a_schema(name: str) -> None:
    ctl = core.CONTROLLERS.get(name)
    assert ctl.name == name
    assert issubclass(ctl.params, ControllerParams)
    schema = ctl.params.model_json_schema()
    assert schema["properties"]["type"].get("const", name) == name
    assert ctl.params.model_fields["period_s"].default > 0
    assert all(r in core.ROBOTS.names() for r in ctl.robots)


@pytest.mark.parametrize("name", core.ROBOTS.names())
def test_every_robot_kind_names_registered_metric_sets(name: str) -> None:
    kind = core.ROBOTS.get(name)
    assert issubclass(kind.params, BaseModel)
    for mset in kind.metrics:
        assert name in (core.METRICS.get(mset).robots or (name,))


@pytest.mark.parametrize("name", core.METRICS.names())
def test_every_metric_set_defines_units_and_directions(name: str) -> None:
    mset = core.METRICS.get(name)
    assert mset.defs
    for metric, d in mset.defs.items():
        assert isinstance(d, MetricDef) and d.unit and d.description, metric
        assert definitions()[metric] == d  # one meaning per metric name across sets


@pytest.mark.parametrize("name", core.WORLDS.names())
def test_every_world_kind_validates_its_own_parameters(name: str) -> None:
    kind = core.WORLDS.get(name)
    assert kind.params.model_json_schema()["properties"]["kind"].get("const", name) == name


def test_unknown_and_misspelt_names_get_one_line_with_a_suggestion(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"controller.type \(from --set\): unknown controller "
                                        r"'mpc' \(did you mean 'mpcc'\?\)"):
        load_scenario("mpcc_lap", ["agents.kart0.controller.type=mpc"], project=active_project())
    with pytest.raises(SpecError, match=r"unknown scenario 'mpcc_lapp' \(did you mean"):
        load_scenario("mpcc_lapp", project=active_project())
    with pytest.raises(SpecError, match=r"agents.kart0.controller.max_speed_mps \(from --set\)"):
        load_scenario("mpcc_lap", ["agents.kart0.controller.max_speed_mps=-1"],
                      project=active_project())
    with pytest.raises(SpecError, match=r"max_speedmps \(from --set\): unknown key \(did you "
                                        r"mean 'max_speed_mps'\?\)"):
        load_scenario("mpcc_lap", ["agents.kart0.controller.max_speedmps=1"],
                      project=active_project())
    with pytest.raises(SpecError, match=r"duraton_s \(from --set\): unknown key \(did you "
                                        r"mean 'duration_s'\?\)"):
        load_scenario("mpcc_lap", ["duraton_s=1"], project=active_project())


def test_a_controller_registered_from_python_drives_a_kart(tmp_path: Path) -> None:
    """A team's controller, registered at run time, runs in the loop with no kartci change."""
    from typing import Any, Literal

    from kartci.core import AgentContext
    from kartci.robots.gokart import KartInput
    from kartci.robots.gokart.joy import kart_command

    class Params(ControllerParams):
        type: Literal["test_throttle"] = "test_throttle"
        accel_mps2: float = 1.0

    class Throttle:
        inputs: tuple[str, ...] = ()

        def __init__(self, params: Params, ctx: AgentContext) -> None:
            self.period_s, self.accel = params.period_s, params.accel_mps2

        def on_message(self, topic: str, message: Any) -> None:
            pass

        def step(self, t_ns: int) -> list[tuple[str, Any]]:
            return [("cmd", kart_command(KartInput(0.0, self.accel, 0.0), t_ns, "base_link"))]

    core.register(Controller("test_throttle", Params, Throttle, ("gokart",)))
    try:
        spec = load_scenario("kart_wall", ["agents.kart0.controller={type: test_throttle, "
                                           "accel_mps2: 2.0}", "duration_s=2"],
                                           project=active_project())
        simulate(spec, tmp_path / "run.mcap")
        m = compute(tmp_path / "run.mcap")[1]
        assert m["max_speed_mps"].value == pytest.approx(4.0, abs=0.4)  # 2 m/s^2 for 2 s
    finally:
        core.CONTROLLERS.items.pop("test_throttle")
    with pytest.raises(SpecError, match="unknown controller 'test_throttle'"):
        load_scenario("kart_wall", ["agents.kart0.controller={type: test_throttle}"],
                      project=active_project())


def test_a_metric_set_registered_from_python_is_computed(tmp_path: Path) -> None:
    from kartci.core import Direction
    from kartci.metrics import Metric, ScoreContext

    def top_x(ctx: ScoreContext, params: Any) -> list[Metric]:
        return [Metric("max_x_m", float(ctx.odom["x"].max()), "m")]

    from typing import Any

    core.register(MetricSet("test_extent", {"max_x_m": MetricDef(
        "m", Direction.EQUAL, 0.01, 0.0, "largest x reached")}, top_x))
    try:
        spec = load_scenario("line_straight", ["duration_s=3", "metrics.test_extent={}",
                                               "metrics.line_tracking.transient_s=1"],
                                               project=active_project())
        simulate(spec, tmp_path / "run.mcap")
        m = compute(tmp_path / "run.mcap")[1]
        odom_x = m["max_x_m"].value
        assert 0.2 < odom_x < 0.5 and "line_lost" in m  # the robot's own sets still run
    finally:
        core.METRICS.items.pop("test_extent")


SHIPPED = sorted(p.stem for p in BUILTIN_SCENARIOS.glob("*.yaml")
                 if (ROOT / "baselines" / f"{p.stem}.json").exists())


# the runs of more than ~5 s of CPU: the full tier checks them (with the others)
HEAVY = {"external_pure_pursuit", "localization_kidnap", "localization_lap", "mpcc_circuit",
         "mpcc_lap", "multi_agent", "obstacle_avoidance", "perception_obstacles"}


@pytest.mark.parametrize("name", [
    pytest.param(n, marks=pytest.mark.long(reason="a full scenario run")) if n in HEAVY else n
    for n in SHIPPED])
def test_every_shipped_scenario_scores_exactly_its_baseline(
        name: str, shipped_run: Callable[[str], Path]) -> None:
    """Refactors keep metrics byte-identical: every value equals the committed baseline's,
    and every shipped scenario meets its own criteria."""
    spec = load_scenario(name, project=active_project())
    got = {k: m.to_json() for k, m in compute(shipped_run(name))[1].items()
           if not (d := definitions().get(k.rsplit(".", 1)[-1])) or not d.timing}
    base = json.loads((ROOT / "baselines" / f"{name}.json").read_text())["metrics"]
    assert {k: v["value"] for k, v in got.items()} == {k: v["value"] for k, v in base.items()}
    failed = [c for c in check_criteria(got, spec.criteria) if not c.ok]
    assert not failed


@pytest.mark.parametrize("topic", ["ackermann_cmd", "cmd_vel"])
def test_karts_take_standard_ackermann_and_twist_commands(topic: str, tmp_path: Path) -> None:
    """A team's controller need not speak kartci_msgs: 3 m/s straight ahead, either way."""
    from typing import Any, Literal

    from kartci.core import AgentContext
    from kartci.logs import header, msg

    class Params(ControllerParams):
        type: Literal["test_standard"] = "test_standard"

    class Cruise:
        inputs: tuple[str, ...] = ()

        def __init__(self, params: Params, ctx: AgentContext) -> None:
            self.period_s = params.period_s

        def on_message(self, topic: str, message: Any) -> None:
            pass

        def step(self, t_ns: int) -> list[tuple[str, Any]]:
            if topic == "ackermann_cmd":
                return [(topic, msg("ackermann_msgs/msg/AckermannDriveStamped",
                                    header=header(t_ns, "kart0/base_link"),
                                    drive=msg("ackermann_msgs/msg/AckermannDrive",
                                              steering_angle=0.0, steering_angle_velocity=0.0,
                                              speed=3.0, acceleration=0.0, jerk=0.0)))]
            v3 = "geometry_msgs/msg/Vector3"
            return [(topic, msg("geometry_msgs/msg/Twist", linear=msg(v3, x=3.0, y=0.0, z=0.0),
                                angular=msg(v3, x=0.0, y=0.0, z=0.0)))]

    core.register(Controller("test_standard", Params, Cruise, ("gokart",)))
    try:
        spec = load_scenario("kart_wall", ["agents.kart0.controller={type: test_standard}",
                                           "duration_s=5"], project=active_project())
        simulate(spec, tmp_path / "run.mcap")
        m = compute(tmp_path / "run.mcap")[1]
    finally:
        core.CONTROLLERS.items.pop("test_standard")
    assert m["max_speed_mps"].value == pytest.approx(3.0, abs=0.15)
    assert m["collisions"].value == 0
