"""kartci's numpy rotations give scipy's Rotation's bits exactly, for every operation APE, RPE
and the alignment use (so metrics did not move when scipy left the scoring path)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from kartci.metrics.quaternion import Rotations


def _quats(rng: np.random.Generator, n: int, planar: bool) -> np.ndarray:
    if planar:  # what a ground robot's log holds: yaw only
        half = rng.uniform(-3.5, 3.5, n)
        zero = np.zeros(n)
        return np.column_stack([zero, zero, np.sin(half), np.cos(half)])
    return np.asarray(rng.normal(size=(n, 4)) * rng.choice([1e-3, 1.0, 1e3]))


def _same(a: np.ndarray, b: np.ndarray) -> None:
    a, b = np.asarray(a), np.asarray(b)
    assert a.shape == b.shape and np.array_equal(a, b)


@pytest.mark.parametrize("seed", range(12))
@pytest.mark.parametrize("planar", [False, True])
def test_every_operation_equals_scipys_bit_for_bit(seed: int, planar: bool) -> None:
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 200))
    q1, q2 = _quats(rng, n, planar), _quats(rng, n, planar)
    r1, r2 = Rotation.from_quat(q1), Rotation.from_quat(q2)
    s1, s2 = Rotations.from_quat(q1), Rotations.from_quat(q2)
    _same(s1.quat, r1.as_quat())
    _same((s1.inv() * s2).quat, (r1.inv() * r2).as_quat())
    _same((s1.inv() * s2).magnitude(), np.atleast_1d((r1.inv() * r2).magnitude()))
    _same(s1.as_matrix(), r1.as_matrix())
    i, j = rng.integers(0, n, n), rng.integers(0, n, n)
    _same((s1[i].inv() * s1[j]).quat, (r1[i].inv() * r1[j]).as_quat())
    vectors = rng.normal(size=(n, 3)) * 10
    _same(s1[i].inv().apply(vectors), r1[i].inv().apply(vectors))
    _same(s1[:1].apply(vectors), r1[:1].apply(vectors))  # one rotation, many vectors
    _same(s1[:1].apply(vectors[:1]), r1[:1].apply(vectors[:1]))
    _same((s1[0] * s2[0].inv()).as_matrix()[0], (r1[0] * r2[0].inv()).as_matrix())


@pytest.mark.parametrize("seed", range(12))
def test_a_matrix_becomes_scipys_quaternion(seed: int) -> None:
    """An Umeyama rotation (U S V^T), a rotation's own matrix, and one a little off orthogonal
    (made orthogonal first), composed with many rotations as the alignment does."""
    rng = np.random.default_rng(seed)
    u, _, vt = np.linalg.svd(rng.normal(size=(3, 3)))
    s = np.diag([1.0, 1.0, -1.0 if np.linalg.det(u) * np.linalg.det(vt) < 0 else 1.0])
    others = rng.normal(size=(50, 4))
    for m in (u @ s @ vt, Rotation.from_quat(rng.normal(size=4)).as_matrix(),
              u @ s @ vt + rng.normal(size=(3, 3)) * 1e-9):
        _same(Rotations.from_matrix(m).quat[0], Rotation.from_matrix(m).as_quat())
        _same((Rotations.from_matrix(m) * Rotations.from_quat(others)).quat,
              (Rotation.from_matrix(m) * Rotation.from_quat(others)).as_quat())


@pytest.mark.parametrize("diagonal", [(1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)])
def test_the_half_turns_and_the_identity_pick_scipys_branch(diagonal: tuple[int, ...]) -> None:
    m = np.diag(np.asarray(diagonal, float))
    _same(Rotations.from_matrix(m).quat[0], Rotation.from_matrix(m).as_quat())


def test_a_zero_quaternion_is_refused_as_scipy_refuses_it() -> None:
    with pytest.raises(ValueError, match="zero norm"):
        Rotations.from_quat([[0.0, 0.0, 0.0, 0.0]])
