"""The line tracker in the loop: its body, line cameras and sonar, publishing under its name."""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from kartci._bullet import pb
from kartci.errors import SpecError
from kartci.logs import header, msg
from kartci.robots.line_tracker.body import LineTracker
from kartci.robots.line_tracker.params import LineTrackerSensors
from kartci.robots.line_tracker.render import unseen_links
from kartci.robots.line_tracker.sensors import LineCamera, Sonar
from kartci.sim.body import BodyState
from kartci.sim.messages import joint_state
from kartci.sim.robot import Put, RobotContext
from kartci.sim.robots import RobotBase, every
from kartci.sim.urdf import urdf_path
from kartci.worlds.line_lab import StraightCourse
from kartci.worlds.line_lab.world import LineLab


class LineTrackerRobot(RobotBase):
    """A line tracker in the loop: its body, two line cameras and an optional sonar; done past the
    end of a straight course."""

    STATIC = ("line_sensor", "line_camera_left", "line_camera_right", "sonar")

    def __init__(self, ctx: RobotContext) -> None:
        world, spec, dt_s = ctx.world, ctx.spec, ctx.dt_s
        if not isinstance(world, LineLab):
            raise SpecError(f"agent {ctx.name}: a line tracker needs a line_lab world, not "
                            f"{world.spec.kind}")
        self.world = world
        self.body = LineTracker(world.client, spec, world.spec, urdf_path(spec.model).parent,
                                dt_s)
        super().__init__(ctx.name, ctx.agent, every(ctx.agent.period_s, dt_s), self.body.frames)
        world.names[self.body.body] = ctx.name  # what others touch (a kart, kartci.gym)
        sensors = spec.sensors
        assert isinstance(sensors, LineTrackerSensors)  # validated by the robot kind
        self.camera = LineCamera(world.client, sensors.line_sensor, world.spec, world)
        self._unseen: list[int] = []  # own links the rendered cameras never see, to hide
        if sensors.line_sensor.mode == "rendered":
            cams = [self.body.frames[f"line_camera_{s}"] for s in ("left", "right")]
            self._unseen = [self.body.link_index[n] for n in unseen_links(
                urdf_path(spec.model), cams, sensors.line_sensor.fov_rad)
                if n in self.body.link_index]
        self.sonar = Sonar(world.client, sensors.sonar) if sensors.sonar.enabled else None
        self.noise_std, self.odom_every, self.rng = (sensors.line_sensor.noise_std,
                                                     ctx.odom_every, ctx.rng)
        self.end_m = world.end_m()
        rate = sensors.line_sensor.update_rate_hz
        self.dt_s, self.frame_dt_s = dt_s, (None if rate is None else 1.0 / rate)
        self.last_frame = -1
        self.images: deque[list[float]] = deque(maxlen=sensors.line_sensor.latency_frames + 1)
        self._st: BodyState | None = None  # base_link's state since the last physics step

    def _state(self) -> BodyState:
        """base_link's state, read from PyBullet once per physics step and only at steps where a
        sensor or done() needs it (most steps between control ticks need none)."""
        if self._st is None:
            self._st = self.body.state()
        return self._st

    def _pose(self, frame: str) -> tuple[np.ndarray, np.ndarray]:
        """World position and rotation of a fixed frame, from this step's state."""
        return self.body.frame_pose(frame, self._state())

    def static_transforms(self) -> list[Any]:
        """tf of the line sensor, both cameras and the sonar mount."""
        return self.static_tf(self.STATIC)

    def sense(self, k: int, t_ns: int, put: Put) -> None:
        """Odometry and wheel speeds at the odometry rate; the line cameras (with noise) at the
        control rate or their own, the sonar at the control rate."""
        if k % self.odom_every == 0:
            self.publish_pose(self._state(), t_ns, put)
            wl, wr = self.body.wheel_speeds()
            put("joint_states", joint_state(t_ns, f"{self.name}/base_link",
                                            ["left_wheel_hinge", "right_wheel_hinge"], [],
                                            [wl, wr]), t_ns)
        if self._camera_due(k):
            self._frame(t_ns, put)
        if k % self.ctrl_every:
            return  # the sonar runs with the controller (source document, Sec. 6.6)
        if self.sonar is not None:
            s = self.sonar.spec
            put("sonar", msg("sensor_msgs/msg/Range", header=header(t_ns, f"{self.name}/sonar"),
                             radiation_type=0,
                             field_of_view=2 * math.atan2(s.cone_radius_m, s.max_range_m),
                             min_range=s.min_range_m, max_range=s.max_range_m,
                             range=self.sonar.range(*self._pose("sonar"))), t_ns)

    def _camera_due(self, k: int) -> bool:
        """A new camera frame at step k: every control tick, or on the cameras' own clock."""
        if self.frame_dt_s is None:
            return k % self.ctrl_every == 0
        frame = math.floor(k * self.dt_s / self.frame_dt_s + 1e-9)
        due = frame != self.last_frame
        self.last_frame = frame
        return due

    def _frame(self, t_ns: int, put: Put) -> None:
        """Both line cameras' luminances (with noise), as one `line_sensor` message."""
        if self._unseen and all(r is self for r in self.world.robots):
            # the renderer skips links with alpha 0; no other robot's camera is here to see them
            for link in self._unseen:
                pb.changeVisualShape(self.body.body, link, rgbaColor=[0, 0, 0, 0],
                                     physicsClientId=self.world.client)
        self._unseen = []
        poses = [self._pose(f"line_camera_{s}") for s in ("left", "right")]
        lum = [v + self.noise_std * float(self.rng.standard_normal())
               for v in self.camera.luminances(poses)]
        self.images.append(lum)
        lum = self.images[0]  # the oldest frame kept: `latency_frames` frames ago, or the first
        put("line_sensor", msg("kartci_msgs/msg/LineSensor",
                               header=header(t_ns, f"{self.name}/line_sensor"),
                               left=lum[0], right=lum[1]), t_ns)

    def apply(self, topic: str, m: Any) -> None:
        """`wheel_cmd` (JointState velocities, rad/s: left, right); other topics are ignored."""
        if topic == "wheel_cmd":
            self.body.command(float(m.velocity[0]), float(m.velocity[1]))

    def pre_step(self, k: int) -> None:
        """Wheel motors, from the latest command through their lag."""
        self._st = None  # the body moves in this step
        self.body.pre_step()

    def post_step(self, t_ns: int, put: Put) -> None:
        """Nothing: a line tracker reports no collisions."""

    def finish(self, put: Put) -> None:
        """Nothing is left open at the end of a run."""

    def reinitialise(self, x_m: float, y_m: float, yaw_rad: float, v_mps: float,
                     yaw_rate_radps: float) -> None:
        """Continue from a recorded state (kartci simreal's windows): pose and motion of the
        body, wheels and their lagged speed targets rolling at that speed."""
        body = self.body
        self._st = None
        body.place(x_m, y_m, yaw_rad, v_mps, yaw_rate_radps)
        half = body.urdf_separation_m / 2
        wheels = [(v_mps - yaw_rate_radps * half) / body.urdf_radius_m,
                  (v_mps + yaw_rate_radps * half) / body.urdf_radius_m]
        self.body.spin(self.body.wheels, wheels)
        self.body.actual_target = [float(w) for w in wheels]

    def done(self, k: int) -> bool:
        """Past the end of a straight course (checked at the odometry rate)."""
        if self.end_m is None or k % self.odom_every:
            return False
        pt = self._pose("line_sensor")[0][:2]
        course = self.world.spec.course
        if (isinstance(course, StraightCourse)
                and math.dist(pt.tolist(), course.start_m) < self.end_m + 0.02 - 1e-6):
            return False  # progress along the line is at most the distance from its start
        return bool(course.progress_m(pt[None, :])[0] > self.end_m + 0.02)
