"""The fixed-step loop: physics, sensors and agents on sim time, every message into the log.

It knows the `Robot` and `SimWorld` contracts only; the registries say which controller, robot
and world classes a scenario names."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kartci import plugins
from kartci.logs import McapLogWriter, msg
from kartci.plugins import AgentContext
from kartci.sim.messages import tf_message
from kartci.sim.robot import Robot, RobotContext, SimWorld
from kartci.spec import Scenario


@dataclass(frozen=True)
class RunInfo:
    sim_time_s: float
    steps: int
    messages: int
    finished_course: bool


def make_world(scenario: Scenario) -> SimWorld:
    """The scenario's world alone, from the world registry (the caller closes it)."""
    world: SimWorld = plugins.WORLDS.get(scenario.world.kind).factory(scenario.world,
                                                                     scenario.physics.dt_s)
    return world


def build_world(scenario: Scenario) -> SimWorld:
    """The scenario's world with its robots and their agents in it (the caller closes it)."""
    dt = scenario.physics.dt_s
    odom_every = round(1.0 / scenario.physics.odom_rate_hz / dt)
    rng = np.random.default_rng(scenario.seed)
    world = make_world(scenario)
    try:
        for name, spec in scenario.agents.items():
            ctx = AgentContext(name, spec.model, tuple(n for n in scenario.agents if n != name))
            agent = plugins.CONTROLLERS.get(spec.controller.type).build(spec.controller, ctx)
            robot_kind = plugins.ROBOTS.get(spec.model.kind)
            world.robots.append(robot_kind.factory(
                RobotContext(name, spec, world, agent, dt, odom_every, rng)))
    except BaseException:
        world.close()
        raise
    return world


class Bus:
    """Writes every message to the log and hands it to the agents that read its topic."""

    def __init__(self, log: McapLogWriter, robots: list[Robot]) -> None:
        self.log, self.count = log, 0
        # full topic -> the agents reading it, and the name each asked for it by
        self.readers: dict[str, list[tuple[Any, str]]] = {}
        for r in robots:
            for want in r.agent.inputs:
                full = want if want.startswith("/") else f"/{r.name}/{want}"
                self.readers.setdefault(full, []).append((r.agent, want))

    def put(self, topic: str, m: Any, t_ns: int) -> None:
        self.log.write(topic, m, t_ns)
        self.count += 1
        for agent, want in self.readers.get(topic, ()):
            agent.on_message(want, m)

    def putter(self, namespace: str) -> Callable[[str, Any, int], None]:
        def put(topic: str, m: Any, t_ns: int) -> None:
            self.put(topic if topic.startswith("/") else f"/{namespace}/{topic}", m, t_ns)
        return put


def simulate(scenario: Scenario, log_path: Path,
             on_progress: Callable[[float], None] | None = None) -> RunInfo:
    """Run a scenario to its end and write its log; raises KartciError on bad input or a
    broken state (a failed run leaves no log behind)."""
    dt_ns = round(scenario.physics.dt_s * 1e9)
    steps = round(scenario.duration_s * 1e9 / dt_ns)
    world = build_world(scenario)
    finished, k = False, 0
    try:
        robots = world.robots
        with McapLogWriter(log_path) as log:
            bus = Bus(log, robots)
            puts = [bus.putter(r.name) for r in robots]
            bus.put("/kartci/scenario", msg("std_msgs/msg/String",
                                            data=scenario.model_dump_json()), 0)
            for topic, m in world.static_messages():
                bus.put(topic, m, 0)
            bus.put("/tf_static", tf_message([t for r in robots for t in r.static_transforms()]),
                    0)
            for k in range(steps + 1):
                t_ns = k * dt_ns
                for r, put in zip(robots, puts, strict=True):
                    r.sense(k, t_ns, put)
                    if k % r.ctrl_every == 0:
                        for topic, m in r.agent.step(t_ns):
                            put(topic, m, t_ns)
                            r.apply(topic, m)
                if all(r.done(k) for r in robots):
                    finished = True
                    break
                if k == steps:
                    break
                for r in robots:
                    r.pre_step(k)
                world.step()
                for r, put in zip(robots, puts, strict=True):
                    r.post_step(t_ns + dt_ns, put)
                if on_progress is not None and k % 500 == 0:
                    on_progress(t_ns * 1e-9)
            for r, put in zip(robots, puts, strict=True):
                r.finish(put)
    finally:
        world.close()
    return RunInfo(k * dt_ns * 1e-9, k, bus.count, finished)
