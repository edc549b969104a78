"""The fixed-step loop: physics, sensors and agents on sim time, every message into the log."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kartci import geometry, project
from kartci.agents import make_agent
from kartci.logs import McapLogWriter, header, msg
from kartci.sim.messages import WORLD_FRAME, pose, tf_message
from kartci.sim.robots import KartRobot, LineTrackerRobot
from kartci.sim.urdf import urdf_path
from kartci.sim.world import World
from kartci.spec import Scenario
from kartci.spec.models import HallWorld, LineLabWorld, StraightCourse
from kartci.track import Track, load_track


@dataclass(frozen=True)
class RunInfo:
    sim_time_s: float
    steps: int
    messages: int
    finished_course: bool


def track_path(world: HallWorld) -> Path:
    """The track file, resolved on the project's world path when the scenario was loaded."""
    p = Path(world.track)
    return p if p.is_absolute() else project.current().world_file(world.track)


def track_of(scenario: Scenario) -> Track | None:
    w = scenario.world
    return load_track(track_path(w)) if isinstance(w, HallWorld) else None


def simulate(scenario: Scenario, log_path: Path,
             on_progress: Callable[[float], None] | None = None) -> RunInfo:
    """Run a scenario to its end and write its log; raises KartciError on bad input or a
    broken state (a failed run leaves no log behind)."""
    dt = scenario.physics.dt_s
    dt_ns = round(dt * 1e9)
    steps = round(scenario.duration_s * 1e9 / dt_ns)
    odom_every = round(1.0 / scenario.physics.odom_rate_hz / dt)
    rng = np.random.default_rng(scenario.seed)
    track = track_of(scenario)
    world = World(scenario.world, dt)
    count, finished, k = 0, False, 0
    try:
        robots: list[LineTrackerRobot | KartRobot] = []
        obstacles = scenario.world.obstacles if isinstance(scenario.world, HallWorld) else ()
        for name, spec in scenario.agents.items():
            agent = make_agent(spec, track, obstacles,
                               tuple(n for n in scenario.agents if n != name))
            model_dir = urdf_path(spec.model).parent
            if isinstance(scenario.world, LineLabWorld):
                robots.append(LineTrackerRobot(name, spec, world, agent, dt, model_dir,
                                               odom_every, rng))
            else:
                assert track is not None
                kart = KartRobot(name, spec, world, agent, dt, model_dir, odom_every, rng,
                                 track, world.names)
                world.names[kart.body.body] = name
                robots.append(kart)
        karts = [r for r in robots if isinstance(r, KartRobot)]
        for kart in karts:
            kart.others = [o for o in karts if o is not kart]
        course = scenario.world.course if isinstance(scenario.world, LineLabWorld) else None
        end_m = geometry.length_m(course) if isinstance(course, StraightCourse) else math.inf

        # full topic -> the agents reading it, and the name each asked for it by
        readers: dict[str, list[tuple[Any, str]]] = {}
        for r in robots:
            for want in r.agent.inputs:
                full = want if want.startswith("/") else f"/{r.name}/{want}"
                readers.setdefault(full, []).append((r.agent, want))

        with McapLogWriter(log_path) as log:
            def putter(robot: LineTrackerRobot | KartRobot) -> Callable[[str, Any, int], None]:
                def put(topic: str, m: Any, t_ns: int) -> None:
                    nonlocal count
                    full = topic if topic.startswith("/") else f"/{robot.name}/{topic}"
                    log.write(full, m, t_ns)
                    count += 1
                    for agent, want in readers.get(full, ()):
                        agent.on_message(want, m)
                return put

            puts = [putter(r) for r in robots]
            log.write("/kartci/scenario", msg("std_msgs/msg/String",
                                              data=scenario.model_dump_json()), 0)
            log.write("/kartci/course", _course_path(scenario, track), 0)
            if isinstance(scenario.world, HallWorld):  # the log carries its track: self-contained
                log.write("/kartci/track", msg("std_msgs/msg/String", data=track_path(
                    scenario.world).read_text(encoding="utf-8")), 0)
                count += 1
            log.write("/tf_static", tf_message([t for r in robots
                                                for t in r.static_transforms()]), 0)
            count += 3
            for k in range(steps + 1):
                t_ns = k * dt_ns
                for r, put in zip(robots, puts, strict=True):
                    r.sense(k, t_ns, put)
                    if k % r.ctrl_every == 0:
                        for topic, m in r.agent.step(t_ns):
                            put(topic, m, t_ns)
                            r.apply(topic, m)
                if (course is not None and end_m < math.inf and k % odom_every == 0
                        and all(isinstance(r, LineTrackerRobot) and r.past_end(course, end_m)
                                for r in robots)):
                    finished = True
                    break
                if k == steps:
                    break
                for r in robots:
                    r.pre_step(k)
                world.step()
                for r, put in zip(robots, puts, strict=True):
                    if isinstance(r, KartRobot):
                        r.track_contacts(t_ns + dt_ns, put)
                if on_progress is not None and k % 500 == 0:
                    on_progress(t_ns * 1e-9)
            for r, put in zip(robots, puts, strict=True):
                if isinstance(r, KartRobot):
                    r.flush_contacts(put)
    finally:
        world.close()
    return RunInfo(k * dt_ns * 1e-9, k, count, finished)


def _course_path(scenario: Scenario, track: Track | None) -> Any:
    if track is not None:
        pts = track.xy[:: max(1, len(track.xy) // 400)]
    else:
        assert isinstance(scenario.world, LineLabWorld)
        pts = geometry.polyline(scenario.world.course, 200)
    poses = [msg("geometry_msgs/msg/PoseStamped", header=header(0, WORLD_FRAME),
                 pose=pose((float(x), float(y), 0.0), (0.0, 0.0, 0.0, 1.0))) for x, y in pts]
    return msg("nav_msgs/msg/Path", header=header(0, WORLD_FRAME), poses=poses)
