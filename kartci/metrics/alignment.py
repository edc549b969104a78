"""Trajectory alignment before APE / RPE, with evo's choices (`evo_ape -a`, `-as`,
`--align_origin`, `--n_to_align`): an estimate in another frame (odometry against AMCL's map,
monocular SLAM at an unknown scale) is moved onto the reference before its error is taken.

SE(3) and Sim(3) are the least-squares fits of S. Umeyama, "Least-squares estimation of
transformation parameters between two point patterns", IEEE TPAMI 13(4), 1991: with the means
mu_x, mu_y, the variance sigma_x^2 = 1/n sum |x_i - mu_x|^2 and the covariance
Sigma_xy = 1/n sum (y_i - mu_y)(x_i - mu_x)^T = U D V^T (eq. 38-39),
R = U S V^T with S = diag(1, ..., 1, det(U) det(V)) (eq. 40, 43), c = tr(D S) / sigma_x^2
(eq. 42, Sim(3) only) and t = mu_y - c R mu_x (eq. 41). evo (GPL) is run as a program by the
tests, never imported.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from kartci.metrics.trajectory import Trajectory, TrajectoryError

__all__ = ["Alignment", "Transform", "align", "umeyama"]


class Alignment(Enum):
    """How the estimate is moved onto the reference before its error is taken."""

    NONE = "none"  # both already in one frame (kartci's own estimate against truth)
    SE3 = "se3"  # rotation and translation, least squares (evo -a)
    SIM3 = "sim3"  # rotation, translation and scale, least squares (evo -as)
    ORIGIN = "origin"  # the first poses made equal (evo --align_origin)


@dataclass(frozen=True)
class Transform:
    """p -> scale * R p + t: the transform applied to the estimate (R 3x3, t in m)."""

    rotation: np.ndarray
    translation_m: np.ndarray
    scale: float = 1.0

    def apply(self, tr: Trajectory) -> Trajectory:
        """The trajectory moved: positions scaled, rotated and shifted, orientations rotated."""
        xyz = self.scale * tr.xyz_m @ self.rotation.T + self.translation_m
        from scipy.spatial.transform import Rotation  # start-up: 0.3 s, only where it aligns

        quat = (Rotation.from_matrix(self.rotation) * tr.rotations()).as_quat()
        return Trajectory(tr.t_s, xyz, quat)


def umeyama(x: np.ndarray, y: np.ndarray, with_scale: bool) -> Transform:
    """The transform minimising sum |y_i - (c R x_i + t)|^2 over points x, y (n x 3, m);
    c = 1 unless `with_scale`. A TrajectoryError when the points are degenerate (all on one
    line or one point: the rotation is not determined)."""
    if x.shape != y.shape or x.ndim != 2 or len(x) < 2:
        raise TrajectoryError(f"alignment needs two or more matched positions, got "
                              f"{len(x)}")
    mu_x, mu_y = x.mean(axis=0), y.mean(axis=0)
    dx, dy = x - mu_x, y - mu_y
    var_x = float(np.mean(np.sum(dx * dx, axis=1)))
    cov = dy.T @ dx / len(x)
    u, d, vt = np.linalg.svd(cov)
    m = cov.shape[0]
    if np.count_nonzero(d > np.finfo(float).eps) < m - 1:
        raise TrajectoryError("the matched positions lie on one line or at one point: a "
                              "rotation cannot be fitted (use --align origin or none)")
    s = np.ones(m)
    s[-1] = -1.0 if np.linalg.det(u) * np.linalg.det(vt) < 0 else 1.0
    rot = u @ np.diag(s) @ vt
    c = float(np.sum(d * s) / var_x) if with_scale else 1.0
    return Transform(rot, mu_y - c * rot @ mu_x, c)


def align(ref: Trajectory, est: Trajectory, how: Alignment,
          first: int | None = None) -> tuple[Trajectory, Transform]:
    """`est` (associated with `ref`, pose for pose) moved onto `ref`, and the transform.
    `first`: fit SE(3) / Sim(3) on the first N pose pairs only (evo's --n_to_align)."""
    if len(ref) != len(est):
        raise TrajectoryError(f"alignment needs associated trajectories, got {len(ref)} and "
                              f"{len(est)} poses")
    if first is not None and first < 2 and how in (Alignment.SE3, Alignment.SIM3):
        raise TrajectoryError(f"alignment on the first {first} poses: it needs two or more")
    if how is Alignment.NONE:
        return est, Transform(np.eye(3), np.zeros(3))
    if how is Alignment.ORIGIN:  # T_ref[0] T_est[0]^-1
        rot = (ref.rotations()[0] * est.rotations()[0].inv()).as_matrix()
        moved = Transform(rot, ref.xyz_m[0] - rot @ est.xyz_m[0])
    else:
        n = len(est) if first is None else min(first, len(est))
        moved = umeyama(est.xyz_m[:n], ref.xyz_m[:n], how is Alignment.SIM3)
    return moved.apply(est), moved
