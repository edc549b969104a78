"""The line-tracker robot as a PyBullet multibody driven through its two wheel joints."""

from __future__ import annotations

import math
from pathlib import Path

from kartci._bullet import pb, quiet_c_output
from kartci.errors import SpecError
from kartci.robots.line_tracker.params import LineTrackerModel
from kartci.scenario.models import AgentSpec
from kartci.sim.body import Base
from kartci.sim.urdf import fixed_frames, physics_urdf
from kartci.worlds.line_lab import LineLabWorld


class LineTracker(Base):
    """Wheels follow their speed targets through a first-order lag (0.1 s on the real robot),
    clamped at the motor saturation speed, and applied by a torque-limited velocity motor."""

    def __init__(self, client: int, spec: AgentSpec, world: LineLabWorld, model_dir: Path,
                 dt_s: float) -> None:
        self.client, self.spec = client, spec
        m = spec.model
        if not isinstance(m, LineTrackerModel):
            raise SpecError(f"model {m.kind} is not a line tracker")
        self.model = m
        sx, sy, yaw0 = world.course.pose_at(spec.start.along_m, spec.start.lateral_m)
        yaw = yaw0 + spec.start.heading_rad
        base = (sx - m.sensor_point_x_m * math.cos(yaw), sy - m.sensor_point_x_m * math.sin(yaw))
        with quiet_c_output():
            body = int(pb.loadURDF(
                str(physics_urdf(model_dir / m.urdf)), [base[0], base[1], 0.0],
                pb.getQuaternionFromEuler([0, 0, yaw]), flags=pb.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=client))
        super().__init__(client, body, fixed_frames(model_dir / m.urdf))
        self.link_index = {"base_link": -1} | {  # PyBullet's link index of each URDF link
            pb.getJointInfo(self.body, j, physicsClientId=client)[12].decode(): j
            for j in range(pb.getNumJoints(self.body, physicsClientId=client))}
        self.wheels = [self.link_index["left_wheel"], self.link_index["right_wheel"]]
        for j in self.wheels:
            pb.changeDynamics(self.body, j, lateralFriction=m.tire_friction, physicsClientId=client)
        # Of base_link's shapes only the caster sphere touches the floor: it slides (frictionless
        # by default).
        pb.changeDynamics(self.body, -1, lateralFriction=m.caster_friction, rollingFriction=0.0,
                          spinningFriction=0.0, physicsClientId=client)
        self._wheel_inertia(m)
        self._alpha = 1.0 - math.exp(-dt_s / m.wheel_time_constant_s) if (
            m.wheel_time_constant_s > 0) else 1.0
        # plain floats, not numpy: the lag runs every physics step (same IEEE operations)
        self.target = [0.0, 0.0]  # commanded wheel speeds, rad/s (left, right)
        self.actual_target = [0.0, 0.0]  # after the first-order lag
        self._forces = [m.wheel_torque_limit_nm] * 2
        self._set_velocity_drive = m.wheel_drive == "set_velocity"
        left, right = (pb.getJointInfo(self.body, j, physicsClientId=client)[14][1]
                       for j in self.wheels)
        # the URDF's wheels; a model whose radius or separation differs moves as that robot
        self.urdf_radius_m = self.rolling_radius(self.wheels[0], m.wheel_radius_m)
        self.urdf_separation_m = abs(left - right)
        self._fresh = False  # a command not yet applied (set_velocity drive)

    def _wheel_inertia(self, m: LineTrackerModel) -> None:
        """Mass and inertia overrides of both wheels (the source document's Gazebo defaults, when
        asked)."""
        for j in self.wheels:
            if m.wheel_mass_kg is not None:
                pb.changeDynamics(self.body, j, mass=m.wheel_mass_kg, physicsClientId=self.client)
            if m.wheel_inertia_kgm2 is not None:
                pb.changeDynamics(self.body, j, localInertiaDiagonal=[m.wheel_inertia_kgm2] * 3,
                                  physicsClientId=self.client)

    def command(self, left_radps: float, right_radps: float) -> None:
        """New wheel-speed targets (rad/s: left, right), clamped at the motor's saturation speed.
        When the model's wheel radius or separation differs from the URDF's, the targets are
        those of the URDF's wheels that move the body as the model's wheels would (so both are
        physical parameters, for calibration); equal, they are used as given."""
        m, lim = self.model, self.model.wheel_speed_limit_radps
        if (m.wheel_radius_m, m.wheel_separation_m) != (self.urdf_radius_m,
                                                        self.urdf_separation_m):
            v = m.wheel_radius_m * (right_radps + left_radps) / 2
            w = m.wheel_radius_m * (right_radps - left_radps) / m.wheel_separation_m
            half = self.urdf_separation_m / 2
            left_radps = (v - w * half) / self.urdf_radius_m
            right_radps = (v + w * half) / self.urdf_radius_m
        self.target = [min(max(left_radps, -lim), lim), min(max(right_radps, -lim), lim)]
        self._fresh = True

    def pre_step(self) -> None:
        """Advance the lagged targets by one physics step and hand them to the wheel motors; or,
        with the `set_velocity` drive, set a new command's wheel speeds once and free the wheels."""
        if self._set_velocity_drive:
            self._set_velocity()
            return
        (a0, a1), (t0, t1), alpha = self.actual_target, self.target, self._alpha
        self.actual_target = [a0 + alpha * (t0 - a0), a1 + alpha * (t1 - a1)]
        pb.setJointMotorControlArray(self.body, self.wheels, pb.VELOCITY_CONTROL,
                                     targetVelocities=self.actual_target,
                                     forces=self._forces, physicsClientId=self.client)

    def wheel_speeds(self) -> tuple[float, float]:
        """Measured wheel speeds, rad/s (left, right)."""
        js = pb.getJointStates(self.body, self.wheels, physicsClientId=self.client)
        return float(js[0][1]), float(js[1][1])

    def _set_velocity(self) -> None:
        """Gazebo's Joint::SetVelocity: the wheel's speed relative to the chassis, at once, then
        nothing holds it (motors off: the wheels roll under contact forces alone)."""
        if self._fresh:
            for j, w in zip(self.wheels, self.target, strict=True):
                angle = pb.getJointState(self.body, j, physicsClientId=self.client)[0]
                pb.resetJointState(self.body, j, angle, float(w), physicsClientId=self.client)
            self._fresh = False
        pb.setJointMotorControlArray(self.body, self.wheels, pb.VELOCITY_CONTROL,
                                     targetVelocities=[0.0, 0.0], forces=[0.0, 0.0],
                                     physicsClientId=self.client)
