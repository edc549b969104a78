"""base_link of a PyBullet body. PyBullet reports and places a base by its centre of mass, so
every pose and twist here is shifted to the URDF's base_link frame."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np

from kartci._bullet import pb

Frames = dict[str, tuple[np.ndarray, np.ndarray]]


def _t3(v: np.ndarray) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


def flat_frames(frames: Frames) -> dict[str, tuple[tuple[float, float, float],
                                                    tuple[float, ...]]]:
    """Each frame's position and row-major rotation as plain floats (for `Base.frame_pose`)."""
    return {name: (_t3(pos), tuple(rot.ravel().tolist())) for name, (pos, rot) in frames.items()}


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
    def rows(self) -> tuple[float, ...]:
        """base_link's rotation (body to world), PyBullet's row-major 9 floats; made once per
        state, however many sensor frames and the IMU read it."""
        return tuple(pb.getMatrixFromQuaternion(self.quat))

    @cached_property
    def rotation(self) -> np.ndarray:
        """`rows` as a 3x3 matrix (read-only: it is shared)."""
        r = np.array(self.rows).reshape(3, 3)
        r.setflags(write=False)
        return r

    @property
    def yaw(self) -> float:
        """Heading about the world's z axis, rad."""
        x, y, z, w = self.quat
        return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


class Reading(NamedTuple):
    """One read of a body's base from PyBullet: centre of mass (world, m), orientation (x, y,
    z, w), linear (m/s) and angular (rad/s) velocity in the world frame, and the rotation as
    PyBullet's row-major 3x3 (body to world)."""

    com: tuple[float, float, float]
    quat: tuple[float, float, float, float]
    lin: tuple[float, float, float]
    ang: tuple[float, float, float]
    rotation: tuple[float, ...]


class Base:
    """A loaded body with the fixed frames of its URDF (sensor mounts)."""

    def __init__(self, client: int, body: int, frames: Frames) -> None:
        self.client, self.body, self.frames = client, body, frames
        self._flat_frames = flat_frames(frames)
        self._com_offset = np.asarray(pb.getDynamicsInfo(body, -1, physicsClientId=client)[3])
        self._com_off = _t3(self._com_offset)

    def read(self) -> Reading:
        """PyBullet's centre-of-mass pose and velocity now (four calls into PyBullet)."""
        c = self.client
        com, quat = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        lin, ang = pb.getBaseVelocity(self.body, physicsClientId=c)
        return Reading(com, quat, lin, ang, pb.getMatrixFromQuaternion(quat))

    def state(self) -> BodyState:
        """Ground truth now: PyBullet's centre-of-mass pose and velocity, moved to base_link."""
        return self.state_of(self.read())

    def state_of(self, rd: Reading) -> BodyState:
        """base_link's state from a reading of the centre of mass. Scalar arithmetic, summed in
        the order numpy's 3x3 products sum (the same bits, a tenth of the time)."""
        r, (o0, o1, o2), (w0, w1, w2) = rd.rotation, self._com_off, rd.ang
        off0 = r[0] * o0 + r[1] * o1 + r[2] * o2
        off1 = r[3] * o0 + r[4] * o1 + r[5] * o2
        off2 = r[6] * o0 + r[7] * o1 + r[8] * o2
        lin = rd.lin
        v0 = lin[0] - (w1 * off2 - w2 * off1)  # - w x off
        v1 = lin[1] - (w2 * off0 - w0 * off2)
        v2 = lin[2] - (w0 * off1 - w1 * off0)
        com, q = rd.com, rd.quat
        return BodyState((com[0] - off0, com[1] - off1, com[2] - off2), (q[0], q[1], q[2], q[3]),
                         (r[0] * v0 + r[3] * v1 + r[6] * v2, r[1] * v0 + r[4] * v1 + r[7] * v2,
                          r[2] * v0 + r[5] * v1 + r[8] * v2),
                         (r[0] * w0 + r[3] * w1 + r[6] * w2, r[1] * w0 + r[4] * w1 + r[7] * w2,
                          r[2] * w0 + r[5] * w1 + r[8] * w2))

    def reset_pose(self, xyz: np.ndarray, quat: tuple[float, float, float, float]) -> None:
        """Place base_link at `xyz`."""
        pb.resetBasePositionAndOrientation(self.body,
                                           (xyz + rotation(quat) @ self._com_offset).tolist(),
                                           quat, physicsClientId=self.client)

    def frame_pose(self, name: str, state: BodyState | None = None) -> tuple[np.ndarray,
                                                                                np.ndarray]:
        """World position and 3x3 rotation of a fixed frame of the URDF (e.g. a sensor mount).
        Scalar arithmetic, summed as numpy's 3x3 products sum (from +0.0, so a sum of -0.0
        terms is +0.0 as there): the same bits, where two BLAS calls cost several µs after a
        physics step has cooled the caches."""
        st = state or self.state()
        a0, a1, a2, b0, b1, b2, c0, c1, c2 = st.rows
        (p0, p1, p2), (m0, m1, m2, m3, m4, m5, m6, m7, m8) = self._flat_frames[name]
        x, y, z = st.xyz
        return (np.array((x + (0.0 + a0 * p0 + a1 * p1 + a2 * p2),
                          y + (0.0 + b0 * p0 + b1 * p1 + b2 * p2),
                          z + (0.0 + c0 * p0 + c1 * p1 + c2 * p2))),
                np.array((0.0 + a0 * m0 + a1 * m3 + a2 * m6, 0.0 + a0 * m1 + a1 * m4 + a2 * m7,
                          0.0 + a0 * m2 + a1 * m5 + a2 * m8, 0.0 + b0 * m0 + b1 * m3 + b2 * m6,
                          0.0 + b0 * m1 + b1 * m4 + b2 * m7, 0.0 + b0 * m2 + b1 * m5 + b2 * m8,
                          0.0 + c0 * m0 + c1 * m3 + c2 * m6, 0.0 + c0 * m1 + c1 * m4 + c2 * m7,
                          0.0 + c0 * m2 + c1 * m5 + c2 * m8)).reshape(3, 3))

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
