"""Rotations as unit quaternions (x, y, z, w) in numpy: the few operations APE, RPE and the
alignment need, each computed with the arithmetic scipy's `Rotation` uses (scipy 1.17's Cython
backend: the same products and sums in the same order, libm's atan2), so every metric keeps
its last bit (tests/metrics/test_quaternion.py compares them with scipy bit for bit). Why not
scipy itself: importing `scipy.spatial` costs ~0.3 s CPU, a sixth of scoring a long log."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Rotations:
    """n rotations: unit quaternions, n x 4, scalar last."""

    quat: np.ndarray

    @classmethod
    def from_quat(cls, quat: Any) -> Rotations:
        """Quaternions normalised to unit length; a ValueError for a zero one."""
        q = np.array(quat, dtype=float, ndmin=2)
        x, y, z, w = q.T
        norm = np.sqrt(x * x + y * y + z * z + w * w)
        if np.any(norm == 0):
            raise ValueError("Found zero norm quaternions in `quat`.")
        return cls(q / norm[:, None])

    @classmethod
    def from_matrix(cls, matrix: np.ndarray) -> Rotations:
        """One rotation from a 3 x 3 matrix (made orthogonal first when it is not to 1e-12);
        a ValueError for a matrix with a non-positive determinant."""
        m = np.array(matrix, dtype=float)
        if np.linalg.det(m) <= 0:
            raise ValueError(f"Non-positive determinant (left-handed or null coordinate "
                             f"frame) in rotation matrix 0: {m}.")
        if not np.all(np.isclose(m @ m.T, np.eye(3), atol=1e-12)):
            u, _, vt = np.linalg.svd(m)
            m = u @ vt
        trace = m[0, 0] + m[1, 1] + m[2, 2]
        decision = [m[0, 0], m[1, 1], m[2, 2], trace]
        choice = max(range(4), key=lambda k: (decision[k], -k))
        q = np.empty(4)
        if choice != 3:
            i, j, k = choice, (choice + 1) % 3, (choice + 2) % 3
            q[i] = 1 - trace + 2 * m[i, i]
            q[j] = m[j, i] + m[i, j]
            q[k] = m[k, i] + m[i, k]
            q[3] = m[k, j] - m[j, k]
        else:
            q[0] = m[2, 1] - m[1, 2]
            q[1] = m[0, 2] - m[2, 0]
            q[2] = m[1, 0] - m[0, 1]
            q[3] = 1 + trace
        return cls.from_quat(q)

    def __len__(self) -> int:
        return len(self.quat)

    def __getitem__(self, index: Any) -> Rotations:
        return Rotations(np.array(self.quat[index], ndmin=2))

    def inv(self) -> Rotations:
        """The inverse rotations (the conjugates)."""
        return Rotations(self.quat * np.array([-1.0, -1.0, -1.0, 1.0]))

    def __mul__(self, other: Rotations) -> Rotations:
        """`self` after `other` (p q); one rotation on either side applies to every other."""
        p, q = self.quat, other.quat
        px, py, pz, pw = (p[:, k] for k in range(4))
        qx, qy, qz, qw = (q[:, k] for k in range(4))
        cx, cy, cz = py * qz - pz * qy, pz * qx - px * qz, px * qy - py * qx
        return Rotations.from_quat(np.column_stack([
            pw * qx + qw * px + cx, pw * qy + qw * py + cy, pw * qz + qw * pz + cz,
            pw * qw - px * qx - py * qy - pz * qz]))  # normalised again, as scipy does

    def magnitude(self) -> np.ndarray:
        """Each rotation's angle, rad, in [0, pi]."""
        x, y, z, w = self.quat.T
        return np.asarray(2 * np.arctan2(np.sqrt(x * x + y * y + z * z), np.abs(w)))

    def as_matrix(self) -> np.ndarray:
        """n x 3 x 3 rotation matrices."""
        x, y, z, w = self.quat.T
        x2, y2, z2, w2 = x * x, y * y, z * z, w * w
        xy, zw, xz, yw, yz, xw = x * y, z * w, x * z, y * w, y * z, x * w
        return np.stack([np.column_stack([x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)]),
                         np.column_stack([2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)]),
                         np.column_stack([2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2])],
                        axis=1)

    def apply(self, vectors: np.ndarray) -> np.ndarray:
        """Each rotation applied to its vector (n x 3, m; one rotation or one vector applies
        to every other), summed as scipy does: matmul for one rotation, einsum for many."""
        matrix, vectors = self.as_matrix(), np.asarray(vectors, float)
        if len(self) == 1 and len(vectors) == 1:
            return np.asarray(np.matmul(matrix, vectors[0]))
        if len(self) == 1:
            return np.asarray(np.matmul(matrix, vectors, axes=[(-2, -1), (-1, -2), (-1, -2)])[0])
        return np.asarray(np.einsum("ijk,ik->ij", matrix, vectors))
