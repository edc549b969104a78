"""The fixed-step loop: physics, sensors and agents on sim time, every message into the log."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kartci import geometry
from kartci.agents import Agent, make_agent
from kartci.errors import RunError
from kartci.logs import McapLogWriter, header, msg
from kartci.sim.line_tracker import LineTracker
from kartci.sim.sensors import LineCamera, Sonar
from kartci.sim.world import World
from kartci.spec import Scenario, project_root
from kartci.spec.models import StraightCourse

STATIC_FRAMES = ("line_sensor", "line_camera_left", "line_camera_right", "sonar")
WORLD_FRAME = "map"


@dataclass(frozen=True)
class RunInfo:
    sim_time_s: float
    steps: int
    messages: int
    finished_course: bool


def _vec(x: float, y: float, z: float) -> Any:
    return msg("geometry_msgs/msg/Vector3", x=x, y=y, z=z)


def _pose(xyz: Any, q: Any) -> Any:
    return msg("geometry_msgs/msg/Pose",
               position=msg("geometry_msgs/msg/Point", x=xyz[0], y=xyz[1], z=xyz[2]),
               orientation=msg("geometry_msgs/msg/Quaternion", x=q[0], y=q[1], z=q[2], w=q[3]))


def _tf(t_ns: int, parent: str, child: str, xyz: Any, q: Any) -> Any:
    tr = msg("geometry_msgs/msg/Transform", translation=_vec(*xyz),
             rotation=msg("geometry_msgs/msg/Quaternion", x=q[0], y=q[1], z=q[2], w=q[3]))
    return msg("geometry_msgs/msg/TransformStamped", header=header(t_ns, parent),
               child_frame_id=child, transform=tr)


class _Robot:
    """One agent's body, sensors and controller, under its namespace."""

    def __init__(self, name: str, scenario: Scenario, world: World) -> None:
        spec = scenario.agents[name]
        self.name = name
        model_dir = project_root() / "models" / spec.model.kind
        self.body = LineTracker(world.client, spec, scenario.world, model_dir,
                                scenario.physics.dt_s)
        self.camera = LineCamera(world.client, spec.line_sensor, scenario.world)
        self.sonar = Sonar(world.client, spec.sonar) if spec.sonar.enabled else None
        self.agent: Agent = make_agent(spec)
        self.ctrl_every = round(spec.controller.period_s / scenario.physics.dt_s)
        self.noise_std = spec.line_sensor.noise_std

    def static_tf(self, t_ns: int) -> list[Any]:
        out = []
        for frame in STATIC_FRAMES:
            rel, rot = self.body.frames[frame]
            out.append(_tf(t_ns, f"{self.name}/base_link", f"{self.name}/{frame}", rel,
                           _quat(rot)))
        return out


def _quat(r: np.ndarray) -> tuple[float, float, float, float]:
    w = math.sqrt(max(0.0, 1 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2, r[2, 1] - r[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2, r[0, 2] - r[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1 - r[0, 0] - r[1, 1] + r[2, 2])) / 2, r[1, 0] - r[0, 1])
    return x, y, z, w


def simulate(scenario: Scenario, log_path: Path,
             on_progress: Callable[[float], None] | None = None) -> RunInfo:
    """Run a scenario to its end and write its log; raises RunError on a broken state."""
    dt_ns = round(scenario.physics.dt_s * 1e9)
    steps = round(scenario.duration_s * 1e9 / dt_ns)
    odom_every = round(1.0 / scenario.physics.odom_rate_hz / scenario.physics.dt_s)
    rng = np.random.default_rng(scenario.seed)
    world = World(scenario.world, scenario.physics.dt_s)
    course = scenario.world.course
    end_m = geometry.length_m(course) if isinstance(course, StraightCourse) else math.inf
    count = 0
    finished = False
    try:
        robots = [_Robot(name, scenario, world) for name in scenario.agents]
        with McapLogWriter(log_path) as log:
            def put(topic: str, m: Any, t_ns: int) -> None:
                nonlocal count
                log.write(topic, m, t_ns)
                count += 1

            put("/kartci/scenario", msg("std_msgs/msg/String", data=scenario.model_dump_json()), 0)
            put("/kartci/course", _course_path(scenario), 0)
            put("/tf_static", msg("tf2_msgs/msg/TFMessage",
                                  transforms=[t for r in robots for t in r.static_tf(0)]), 0)
            k = 0
            for k in range(steps + 1):
                t_ns = k * dt_ns
                for r in robots:
                    if k % odom_every == 0:
                        _publish_state(r, t_ns, put)
                    if k % r.ctrl_every == 0:
                        _control(r, t_ns, put, rng)
                if (k % odom_every == 0 and isinstance(course, StraightCourse)
                        and _past_end(robots, course, end_m)):
                    finished = True
                    break
                if k == steps:
                    break
                for r in robots:
                    r.body.pre_step()
                world.step()
                if on_progress is not None and k % 500 == 0:
                    on_progress(t_ns * 1e-9)
    finally:
        world.close()
    return RunInfo(k * dt_ns * 1e-9, k, count, finished)


def _past_end(robots: list[_Robot], course: StraightCourse, end_m: float) -> bool:
    pts = np.array([r.body.frame_pose("line_sensor")[0][:2] for r in robots])
    return bool((geometry.progress_m(course, pts) > end_m + 0.02).all())


def _course_path(scenario: Scenario) -> Any:
    poses = []
    for x, y in geometry.polyline(scenario.world.course, 200):
        poses.append(msg("geometry_msgs/msg/PoseStamped", header=header(0, WORLD_FRAME),
                         pose=_pose((x, y, 0.0), (0.0, 0.0, 0.0, 1.0))))
    return msg("nav_msgs/msg/Path", header=header(0, WORLD_FRAME), poses=poses)


def _publish_state(r: _Robot, t_ns: int, put: Callable[[str, Any, int], None]) -> None:
    st = r.body.state()
    if not all(math.isfinite(v) for v in (*st.xyz, *st.v_body)):
        raise RunError(f"agent {r.name}: non-finite state at t={t_ns * 1e-9:.3f} s")
    ns = r.name
    zeros36 = np.zeros(36)
    odom = msg("nav_msgs/msg/Odometry", header=header(t_ns, WORLD_FRAME),
               child_frame_id=f"{ns}/base_link",
               pose=msg("geometry_msgs/msg/PoseWithCovariance", pose=_pose(st.xyz, st.quat),
                        covariance=zeros36),
               twist=msg("geometry_msgs/msg/TwistWithCovariance",
                         twist=msg("geometry_msgs/msg/Twist", linear=_vec(*st.v_body),
                                   angular=_vec(*st.w_body)),
                         covariance=zeros36))
    put(f"/{ns}/odom", odom, t_ns)
    put("/tf", msg("tf2_msgs/msg/TFMessage",
                   transforms=[_tf(t_ns, WORLD_FRAME, f"{ns}/base_link", st.xyz, st.quat)]), t_ns)
    wl, wr = r.body.wheel_speeds()
    js = msg("sensor_msgs/msg/JointState", header=header(t_ns, f"{ns}/base_link"),
             name=["left_wheel_hinge", "right_wheel_hinge"], position=np.zeros(0),
             velocity=np.array([wl, wr]), effort=np.zeros(0))
    put(f"/{ns}/joint_states", js, t_ns)


def _control(r: _Robot, t_ns: int, put: Callable[[str, Any, int], None],
             rng: np.random.Generator) -> None:
    ns = r.name
    st = r.body.state()
    poses = [r.body.frame_pose(f"line_camera_{side}", st) for side in ("left", "right")]
    lum = [v + r.noise_std * float(rng.standard_normal()) for v in r.camera.luminances(poses)]
    line = msg("kartci_msgs/msg/LineSensor", header=header(t_ns, f"{ns}/line_sensor"),
               left=lum[0], right=lum[1])
    put(f"/{ns}/line_sensor", line, t_ns)
    r.agent.on_message("line_sensor", line)
    if r.sonar is not None:
        pos, rot = r.body.frame_pose("sonar", st)
        s = r.sonar.spec
        rng_msg = msg("sensor_msgs/msg/Range", header=header(t_ns, f"{ns}/sonar"),
                      radiation_type=0, field_of_view=2 * math.atan2(s.cone_radius_m,
                                                                     s.max_range_m),
                      min_range=s.min_range_m, max_range=s.max_range_m,
                      range=r.sonar.range(pos, rot))
        put(f"/{ns}/sonar", rng_msg, t_ns)
        r.agent.on_message("sonar", rng_msg)
    for topic, m in r.agent.step(t_ns):
        put(f"/{ns}/{topic}", m, t_ns)
        if topic == "wheel_cmd":
            r.body.command(float(m.velocity[0]), float(m.velocity[1]))
