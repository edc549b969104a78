"""base_link of a PyBullet body. PyBullet reports and places a base by its centre of mass, so
every pose and twist here is shifted to the URDF's base_link frame."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from kartci._bullet import pb

Frames = dict[str, tuple[np.ndarray, np.ndarray]]


def _t3(v: np.ndarray) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


def rotation(quat: tuple[float, float, float, float]) -> np.ndarray:
    """The 3x3 rotation matrix of a quaternion (x, y, z, w)."""
    return np.array(pb.getMatrixFromQuaternion(quat)).reshape(3, 3)


@dataclass(frozen=True)
class BodyState:
    """Ground truth of base_link: world pose and body-frame twist."""

    xyz: tuple[float, float, float]
    quat: tuple[float, float, float, float]  # x, y, z, w
    v_body: tuple[float, float, float]  # m/s in base_link
    w_body: tuple[float, float, float]  # rad/s in base_link

    @cached_property
    def rotation(self) -> np.ndarray:
        """base_link's orientation as a 3x3 rotation matrix (body to world); made once per
        state, however many sensor frames read it (read-only: it is shared)."""
        r = rotation(self.quat)
        r.setflags(write=False)
        return r

    @property
    def yaw(self) -> float:
        """Heading about the world's z axis, rad."""
        x, y, z, w = self.quat
        return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


class Base:
    """A loaded body with the fixed frames of its URDF (sensor mounts)."""

    def __init__(self, client: int, body: int, frames: Frames) -> None:
        self.client, self.body, self.frames = client, body, frames
        self._com_offset = np.asarray(pb.getDynamicsInfo(body, -1, physicsClientId=client)[3])

    def state(self) -> BodyState:
        """Ground truth now: PyBullet's centre-of-mass pose and velocity, moved to base_link."""
        c = self.client
        com, quat = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        lin, ang = pb.getBaseVelocity(self.body, physicsClientId=c)
        rot = rotation(quat)
        off = rot @ self._com_offset
        w = np.asarray(ang)
        v = np.asarray(lin) - np.array([w[1] * off[2] - w[2] * off[1],  # - w x off, no BLAS
                                        w[2] * off[0] - w[0] * off[2],
                                        w[0] * off[1] - w[1] * off[0]])
        return BodyState(_t3(np.asarray(com) - off), (quat[0], quat[1], quat[2], quat[3]),
                         _t3(rot.T @ v), _t3(rot.T @ w))

    def reset_pose(self, xyz: np.ndarray, quat: tuple[float, float, float, float]) -> None:
        """Place base_link at `xyz`."""
        pb.resetBasePositionAndOrientation(self.body,
                                           (xyz + rotation(quat) @ self._com_offset).tolist(),
                                           quat, physicsClientId=self.client)

    def frame_pose(self, name: str, state: BodyState | None = None) -> tuple[np.ndarray,
                                                                                np.ndarray]:
        """World position and 3x3 rotation of a fixed frame of the URDF (e.g. a sensor mount)."""
        st = state or self.state()
        rot = st.rotation
        rel_pos, rel_rot = self.frames[name]
        return np.asarray(st.xyz) + rot @ rel_pos, rot @ rel_rot

    def place(self, x_m: float, y_m: float, yaw_rad: float, v_mps: float,
              yaw_rate_radps: float) -> None:
        """Put base_link at (x, y, yaw) on the plane, keeping its height, moving forward at
        `v_mps` and turning at `yaw_rate_radps`: a sim re-initialised from a recorded state
        (kartci simreal's windows)."""
        c = self.client
        z = self.state().xyz[2]
        quat = pb.getQuaternionFromEuler([0.0, 0.0, yaw_rad])
        self.reset_pose(np.array([x_m, y_m, z]), quat)
        off = rotation(quat) @ self._com_offset
        w = np.array([0.0, 0.0, yaw_rate_radps])
        lin = np.array([v_mps * math.cos(yaw_rad), v_mps * math.sin(yaw_rad), 0.0])
        pb.resetBaseVelocity(self.body, (lin + np.cross(w, off)).tolist(), w.tolist(),
                             physicsClientId=c)

    def spin(self, joints: list[int], speeds_radps: list[float]) -> None:
        """Set joints turning at these speeds (rad/s), keeping their angles."""
        for j, w in zip(joints, speeds_radps, strict=True):
            angle = pb.getJointState(self.body, j, physicsClientId=self.client)[0]
            pb.resetJointState(self.body, j, angle, w, physicsClientId=self.client)

    def rolling_radius(self, link: int, default_m: float) -> float:
        """A wheel's radius as its collision shape has it (sphere or cylinder), m; `default_m`
        for any other shape. A model parameter of the same name may differ on purpose (the
        radius a motor controller believes in)."""
        shapes = pb.getCollisionShapeData(self.body, link, physicsClientId=self.client)
        if not shapes:
            return default_m
        geom, dims = shapes[0][2], shapes[0][3]
        if geom == pb.GEOM_SPHERE:
            return float(dims[0])
        if geom == pb.GEOM_CYLINDER:
            return float(dims[1])
        return default_m
