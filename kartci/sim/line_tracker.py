"""The line-tracker robot as a PyBullet multibody driven through its two wheel joints."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kartci import geometry
from kartci._bullet import pb, quiet_c_output
from kartci.errors import SpecError
from kartci.sim.urdf import fixed_frames, physics_urdf
from kartci.spec.models import AgentSpec, LineLabWorld, LineTrackerModel


@dataclass(frozen=True)
class BodyState:
    """Ground truth of base_link: world pose and body-frame twist."""

    xyz: tuple[float, float, float]
    quat: tuple[float, float, float, float]  # x, y, z, w
    v_body: tuple[float, float, float]  # m/s in base_link
    w_body: tuple[float, float, float]  # rad/s in base_link


def _t3(v: np.ndarray) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


class LineTracker:
    """Wheels follow their speed targets through a first-order lag (0.1 s on the real robot),
    clamped at the motor saturation speed, and applied by a torque-limited velocity motor."""

    def __init__(self, client: int, spec: AgentSpec, world: LineLabWorld, model_dir: Path,
                 dt_s: float) -> None:
        self.client, self.spec = client, spec
        m = spec.model
        if not isinstance(m, LineTrackerModel):
            raise SpecError(f"model {m.kind} is not a line tracker")
        self.model = m
        sx, sy, yaw0 = geometry.pose_at(world.course, spec.start.along_m, spec.start.lateral_m)
        yaw = yaw0 + spec.start.heading_rad
        base = (sx - m.sensor_point_x_m * math.cos(yaw), sy - m.sensor_point_x_m * math.sin(yaw))
        with quiet_c_output():
            self.body = int(pb.loadURDF(
                str(physics_urdf(model_dir / m.urdf)), [base[0], base[1], 0.0],
                pb.getQuaternionFromEuler([0, 0, yaw]), flags=pb.URDF_USE_INERTIA_FROM_FILE,
                physicsClientId=client))
        self.frames = fixed_frames(model_dir / m.urdf)
        links = {pb.getJointInfo(self.body, j, physicsClientId=client)[12].decode(): j
                 for j in range(pb.getNumJoints(self.body, physicsClientId=client))}
        self.wheels = [links["left_wheel"], links["right_wheel"]]
        for j in self.wheels:
            pb.changeDynamics(self.body, j, lateralFriction=m.tire_friction, physicsClientId=client)
        # Of base_link's shapes only the caster sphere touches the floor: make it frictionless.
        pb.changeDynamics(self.body, -1, lateralFriction=0.0, rollingFriction=0.0,
                          spinningFriction=0.0, physicsClientId=client)
        self._alpha = 1.0 - math.exp(-dt_s / m.wheel_time_constant_s) if (
            m.wheel_time_constant_s > 0) else 1.0
        self._com_offset = np.asarray(pb.getDynamicsInfo(self.body, -1, physicsClientId=client)[3])
        self.target = np.zeros(2)  # commanded wheel speeds, rad/s (left, right)
        self.actual_target = np.zeros(2)  # after the first-order lag

    def command(self, left_radps: float, right_radps: float) -> None:
        lim = self.model.wheel_speed_limit_radps
        self.target = np.clip([left_radps, right_radps], -lim, lim)

    def pre_step(self) -> None:
        self.actual_target += self._alpha * (self.target - self.actual_target)
        tau = self.model.wheel_torque_limit_nm
        pb.setJointMotorControlArray(self.body, self.wheels, pb.VELOCITY_CONTROL,
                                     targetVelocities=self.actual_target.tolist(),
                                     forces=[tau, tau], physicsClientId=self.client)

    def state(self) -> BodyState:
        c = self.client
        com, quat = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        lin, ang = pb.getBaseVelocity(self.body, physicsClientId=c)
        rot = np.array(pb.getMatrixFromQuaternion(quat)).reshape(3, 3)
        off = rot @ self._com_offset  # PyBullet reports the base's centre of mass, not base_link
        pos = np.asarray(com) - off
        w = np.asarray(ang)
        v = np.asarray(lin) - np.array([w[1] * off[2] - w[2] * off[1],
                                        w[2] * off[0] - w[0] * off[2],
                                        w[0] * off[1] - w[1] * off[0]])
        return BodyState(_t3(pos), (quat[0], quat[1], quat[2], quat[3]), _t3(rot.T @ v),
                         _t3(rot.T @ w))

    def reset_pose(self, xyz: np.ndarray, quat: tuple[float, float, float, float]) -> None:
        """Place base_link at `xyz` (PyBullet positions the centre of mass)."""
        rot = np.array(pb.getMatrixFromQuaternion(quat)).reshape(3, 3)
        pb.resetBasePositionAndOrientation(self.body, (xyz + rot @ self._com_offset).tolist(),
                                           quat, physicsClientId=self.client)

    def wheel_speeds(self) -> tuple[float, float]:
        js = pb.getJointStates(self.body, self.wheels, physicsClientId=self.client)
        return float(js[0][1]), float(js[1][1])

    def frame_pose(self, name: str, state: BodyState | None = None) -> tuple[np.ndarray,
                                                                                np.ndarray]:
        """World position and 3x3 rotation of a fixed frame of the URDF (e.g. a sensor mount)."""
        st = state or self.state()
        rot = np.array(pb.getMatrixFromQuaternion(st.quat)).reshape(3, 3)
        rel_pos, rel_rot = self.frames[name]
        return np.asarray(st.xyz) + rot @ rel_pos, rot @ rel_rot
