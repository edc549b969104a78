"""Trajectory errors with evo's conventions: APE and RPE between a reference and an estimate.

The definitions follow evo (github.com/MichaelGrupp/evo, `evo.core.metrics` and
`evo.core.filters`), so a number kartci reports equals what `evo_ape` / `evo_rpe` print for the
same two trajectories written as TUM files (`Trajectory.to_tum`); a test runs evo's command
line to prove it. evo is GPL and is never imported here.

- Association (`associate`): evo's `associate_trajectories`, nearest stamp within
  `max_diff_s`, starting from the trajectory with fewer poses.
- APE: per associated pose, the translation error |p_est - p_ref| (m) or the angle of the
  relative rotation R_est^-1 R_ref (deg); no alignment (kartci's estimate and truth share the
  world frame).
- RPE: for index pairs (i, j) chosen by a delta in frames, metres of travelled path (evo's
  consecutive-pairs rule: the next pose once the path since the last one reaches delta) or
  seconds (kartci's own, the same rule on time), chosen on the estimate as evo does by
  default, the error of the relative motion
  E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j): its translation norm (m) or rotation angle (deg).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from kartci.errors import KartciError

if TYPE_CHECKING:
    from scipy.spatial.transform import Rotation

__all__ = ["DeltaUnit", "ErrorStats", "Relation", "Trajectory", "TrajectoryError", "ape",
           "ape_errors", "associate", "rpe", "rpe_errors"]

# A pair of stamps `delta` seconds apart counts as `delta` even when float sums of a fixed rate
# fall a hair short (0.1 s * 10 = 0.9999999999999999 s).
_TIME_EPS_S = 1e-9


class TrajectoryError(KartciError):
    """Two trajectories that cannot be compared (no common stamps, too short, malformed)."""


class Relation(Enum):
    """Which part of the pose error a statistic is about."""

    TRANSLATION = "translation"  # m
    ROTATION_DEG = "rotation_deg"  # deg


class DeltaUnit(Enum):
    """The unit of the RPE's delta between the two poses of a pair."""

    FRAMES = "frames"
    METERS = "meters"  # travelled path of the estimate (evo's default)
    SECONDS = "seconds"


@dataclass(frozen=True)
class Trajectory:
    """Timestamped poses in one frame: stamps (s), positions (m), unit quaternions (x, y, z, w)."""

    t_s: np.ndarray
    xyz_m: np.ndarray
    quat_xyzw: np.ndarray

    def __post_init__(self) -> None:
        n = len(self.t_s)
        if n == 0:
            raise TrajectoryError("a trajectory needs at least one pose")
        if self.xyz_m.shape != (n, 3) or self.quat_xyzw.shape != (n, 4):
            raise TrajectoryError(f"a trajectory of {n} stamps needs {n}x3 positions and {n}x4 "
                                  f"quaternions, got {self.xyz_m.shape} and "
                                  f"{self.quat_xyzw.shape}")

    def __len__(self) -> int:
        return len(self.t_s)

    @classmethod
    def planar(cls, t_s: np.ndarray, x_m: np.ndarray, y_m: np.ndarray,
               yaw_rad: np.ndarray) -> Trajectory:
        """Poses on the ground plane (z 0, rotation about z only)."""
        half = np.asarray(yaw_rad, float) / 2.0
        zeros = np.zeros_like(half)
        return cls(np.asarray(t_s, float), np.column_stack([x_m, y_m, zeros]),
                   np.column_stack([zeros, zeros, np.sin(half), np.cos(half)]))

    @classmethod
    def from_odometry(cls, df: pd.DataFrame) -> Trajectory:
        """From a table of `kartci.logs.tables` for nav_msgs/Odometry (or PoseStamped): the
        orientation quaternion when the table has it, else its yaw."""
        if {"qx", "qy", "qz", "qw"} <= set(df.columns):
            return cls(df["t"].to_numpy(float), df[["x", "y", "z"]].to_numpy(float),
                       df[["qx", "qy", "qz", "qw"]].to_numpy(float))
        return cls.planar(df["t"].to_numpy(float), df["x"].to_numpy(float),
                          df["y"].to_numpy(float), df["yaw"].to_numpy(float))

    def to_tum(self, path: Path) -> None:
        """Write the TUM format evo reads: `t x y z qx qy qz qw`, one pose per line."""
        rows = np.column_stack([self.t_s, self.xyz_m, self.quat_xyzw])
        np.savetxt(path, rows, fmt="%.17g", header="timestamp tx ty tz qx qy qz qw")

    @classmethod
    def from_tum(cls, path: Path) -> Trajectory:
        """Read a TUM file (`#` comments, whitespace or commas between the 8 columns)."""
        try:
            text = Path(path).read_text().replace(",", " ")
            rows = np.loadtxt(text.splitlines(), comments="#", ndmin=2)
        except (OSError, ValueError) as err:
            raise TrajectoryError(f"{path}: not a TUM trajectory ({err})") from err
        if rows.shape[1] != 8:
            raise TrajectoryError(f"{path}: a TUM trajectory has 8 columns per line, this has "
                                  f"{rows.shape[1]}")
        return cls(rows[:, 0], rows[:, 1:4], rows[:, 4:8])

    def take(self, idx: np.ndarray) -> Trajectory:
        """The poses at these indices."""
        return Trajectory(self.t_s[idx], self.xyz_m[idx], self.quat_xyzw[idx])

    def rotations(self) -> Rotation:
        """The orientations as scipy rotations (quaternions normalised, as evo does)."""
        from scipy.spatial.transform import Rotation  # start-up: 0.3 s, only where it scores

        return Rotation.from_quat(self.quat_xyzw)


@dataclass(frozen=True)
class ErrorStats:
    """evo's statistics of an error array, in the error's unit (m or deg)."""

    rmse: float
    mean: float
    median: float
    std: float
    min: float
    max: float
    sse: float
    count: int

    @classmethod
    def of(cls, errors: np.ndarray) -> ErrorStats:
        """Statistics of a non-empty error array (std is the population std, as numpy's)."""
        if len(errors) == 0:
            raise TrajectoryError("no pose pairs to compute an error over")
        sq = np.square(errors)
        return cls(float(np.sqrt(np.mean(sq))), float(np.mean(errors)),
                   float(np.median(errors)), float(np.std(errors)), float(np.min(errors)),
                   float(np.max(errors)), float(np.sum(sq)), len(errors))


def _match(short_t: np.ndarray, long_t: np.ndarray,
           max_diff_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices of each short stamp's nearest long stamp within `max_diff_s` (evo's binary
    search: ties go to the earlier stamp); needs `long_t` sorted."""
    idx = np.clip(np.searchsorted(long_t, short_t, side="right"), 0, len(long_t) - 1)
    diff_ub = long_t[idx] - short_t
    prev = np.maximum(idx - 1, 0)
    diff_lb = np.where(idx > 0, short_t - long_t[prev], np.inf)
    in_range = (short_t >= long_t[0] - max_diff_s) & (short_t <= long_t[-1] + max_diff_s)
    take_ub = (diff_ub <= max_diff_s) & (diff_ub < diff_lb)
    take_lb = ~take_ub & (diff_lb <= max_diff_s) & (diff_lb <= diff_ub)
    ok = in_range & (take_ub | take_lb)
    best = np.where(take_ub, idx, prev)
    return np.flatnonzero(ok), best[ok]


def associate(ref: Trajectory, est: Trajectory, max_diff_s: float = 0.01,
              offset_s: float = 0.0) -> tuple[Trajectory, Trajectory]:
    """The poses of `ref` and `est` whose stamps match within `max_diff_s` (s), `offset_s`
    added to the estimate's stamps; evo's `associate_trajectories` (nearest time)."""
    for name, tr in (("reference", ref), ("estimate", est)):
        if np.any(np.diff(tr.t_s) < 0):
            raise TrajectoryError(f"the {name}'s stamps are not sorted")
    est_longer = len(est) > len(ref)
    short, long_ = (ref, est) if est_longer else (est, ref)
    shift = offset_s if est_longer else -offset_s
    i_short, i_long = _match(short.t_s, long_.t_s + shift, max_diff_s)
    if len(i_short) == 0:
        raise TrajectoryError(f"no stamps of the reference and the estimate match within "
                              f"{max_diff_s} s (offset {offset_s} s)")
    a, b = short.take(i_short), long_.take(i_long)
    return (a, b) if est_longer else (b, a)


def _rotation_angle_deg(r: Rotation) -> np.ndarray:
    return np.asarray(np.rad2deg(np.atleast_1d(r.magnitude())), float)


def ape_errors(ref: Trajectory, est: Trajectory,
               relation: Relation = Relation.TRANSLATION) -> np.ndarray:
    """Per pose of two associated trajectories: translation error (m) or rotation angle
    (deg)."""
    if len(ref) != len(est):
        raise TrajectoryError(f"APE needs associated trajectories, got {len(ref)} and "
                              f"{len(est)} poses")
    if relation is Relation.TRANSLATION:
        return np.asarray(np.linalg.norm(est.xyz_m - ref.xyz_m, axis=1))
    return _rotation_angle_deg(est.rotations().inv() * ref.rotations())


def ape(ref: Trajectory, est: Trajectory,
        relation: Relation = Relation.TRANSLATION) -> ErrorStats:
    """Absolute pose error statistics of two associated trajectories (no alignment)."""
    return ErrorStats.of(ape_errors(ref, est, relation))


def _consecutive(steps: np.ndarray, delta: float, eps: float = 0.0) -> list[int]:
    """evo's consecutive-pairs rule: sum the steps (path or time) from the last chosen pose,
    and choose the next pose once the sum reaches `delta`, then start again from 0 (summed in
    evo's order, so the same poses are chosen to the last bit)."""
    ids, total = [0], 0.0
    for i, step in enumerate(steps.tolist(), start=1):
        total += step
        if total >= delta - eps:
            ids.append(i)
            total = 0.0
    return ids


def _pair_ids(est: Trajectory, delta: float, unit: DeltaUnit,
              all_pairs: bool) -> list[tuple[int, int]]:
    """Index pairs (i, j) delta apart, chosen on the estimate as evo does by default."""
    n = len(est)
    if unit is DeltaUnit.FRAMES:
        step = int(delta)
        if step != delta or step < 1:
            raise TrajectoryError(f"an RPE delta in frames must be a whole number >= 1, got "
                                  f"{delta}")
        if all_pairs:
            return [(i, i + step) for i in range(n - step)]
        ids = list(range(0, n, step))
    elif all_pairs:
        raise TrajectoryError("all_pairs is only supported with a delta in frames")
    elif unit is DeltaUnit.METERS:
        ids = _consecutive(np.linalg.norm(np.diff(est.xyz_m, axis=0), axis=1), delta)
    else:
        ids = _consecutive(np.diff(est.t_s), delta, _TIME_EPS_S)
    return list(itertools.pairwise(ids))


def rpe_errors(ref: Trajectory, est: Trajectory, delta: float,
               unit: DeltaUnit = DeltaUnit.METERS, relation: Relation = Relation.TRANSLATION,
               all_pairs: bool = False) -> np.ndarray:
    """Per pose pair of two associated trajectories: the relative-motion error, translation
    (m) or rotation angle (deg)."""
    if len(ref) != len(est):
        raise TrajectoryError(f"RPE needs associated trajectories, got {len(ref)} and "
                              f"{len(est)} poses")
    pairs = _pair_ids(est, delta, unit, all_pairs)
    if not pairs:
        raise TrajectoryError(f"an RPE delta of {delta} {unit.value} gives no pose pairs: the "
                              f"trajectory is shorter than that")
    i, j = (np.array(p) for p in zip(*pairs, strict=True))
    rq, rp = ref.rotations(), est.rotations()
    q_rel_r = rq[i].inv() * rq[j]
    p_rel_r = rp[i].inv() * rp[j]
    q_rel_t = rq[i].inv().apply(ref.xyz_m[j] - ref.xyz_m[i])
    p_rel_t = rp[i].inv().apply(est.xyz_m[j] - est.xyz_m[i])
    if relation is Relation.TRANSLATION:  # E = Q_rel^-1 P_rel: translation R_Q^T (t_P - t_Q)
        return np.asarray(np.linalg.norm(q_rel_r.inv().apply(p_rel_t - q_rel_t), axis=1))
    return _rotation_angle_deg(q_rel_r.inv() * p_rel_r)


def rpe(ref: Trajectory, est: Trajectory, delta: float, unit: DeltaUnit = DeltaUnit.METERS,
        relation: Relation = Relation.TRANSLATION, all_pairs: bool = False) -> ErrorStats:
    """Relative pose error statistics of two associated trajectories."""
    return ErrorStats.of(rpe_errors(ref, est, delta, unit, relation, all_pairs))
