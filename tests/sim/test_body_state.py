"""base_link's state from one reading of the centre of mass, in scalars: numpy's bits (the
formula it replaced) for any orientation, offset and motion."""

from __future__ import annotations

import numpy as np

from kartci._bullet import pb
from kartci.sim.body import Base, BodyState, Reading


def _numpy_state(rd: Reading, offset: np.ndarray) -> BodyState:
    """kartci.sim.body.Base.state at eab3d56, on a reading."""
    rot = np.array(rd.rotation).reshape(3, 3)
    off = rot @ offset
    w = np.asarray(rd.ang)
    v = np.asarray(rd.lin) - np.array([w[1] * off[2] - w[2] * off[1],
                                       w[2] * off[0] - w[0] * off[2],
                                       w[0] * off[1] - w[1] * off[0]])
    xyz, vb, wb = np.asarray(rd.com) - off, rot.T @ v, rot.T @ w
    q = rd.quat
    return BodyState((float(xyz[0]), float(xyz[1]), float(xyz[2])), (q[0], q[1], q[2], q[3]),
                     (float(vb[0]), float(vb[1]), float(vb[2])),
                     (float(wb[0]), float(wb[1]), float(wb[2])))


def test_state_of_a_reading_equals_numpys_products() -> None:
    rng = np.random.default_rng(11)
    base = Base.__new__(Base)  # no body: state_of needs the centre of mass offset only
    for _ in range(2000):
        offset = rng.normal(scale=0.2, size=3)
        base._com_off = (float(offset[0]), float(offset[1]), float(offset[2]))
        q = rng.normal(size=4)
        quat = tuple((q / np.linalg.norm(q)).tolist())
        rd = Reading(tuple(rng.normal(scale=10.0, size=3).tolist()), quat,
                     tuple(rng.normal(scale=5.0, size=3).tolist()),
                     tuple(rng.normal(size=3).tolist()), pb.getMatrixFromQuaternion(quat))
        assert base.state_of(rd) == _numpy_state(rd, offset)
