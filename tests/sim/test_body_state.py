"""base_link's state from one reading of the centre of mass, in scalars: numpy's bits (the
formula it replaced) for any orientation, offset and motion."""

from __future__ import annotations

import numpy as np

from kartci._bullet import pb
from kartci.sim.body import Base, BodyState, Reading, flat_frames


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


def test_frame_pose_equals_numpys_products() -> None:
    """A fixed frame's world pose, in scalars: the bits of the numpy products it replaced."""
    rng = np.random.default_rng(12)
    for k in range(2000):
        q = rng.normal(size=4)
        st = BodyState(tuple(rng.normal(scale=10.0, size=3).tolist()),
                       tuple((q / np.linalg.norm(q)).tolist()), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        qf = rng.normal(size=4)
        rel_pos = rng.normal(scale=0.3, size=3)
        rel_rot = np.array(pb.getMatrixFromQuaternion(qf / np.linalg.norm(qf))).reshape(3, 3)
        if k % 4 == 0:  # URDF mounts: exact (signed) zeros, and poses with exact zeros
            rel_pos, rel_rot = np.array([0.1, -0.0, 0.0]), np.array([[0.0, -0.0, 1.0],
                                                                    [-1.0, 0.0, -0.0],
                                                                    [-0.0, -1.0, 0.0]])
            st = BodyState(st.xyz, (0.0, 0.0, -0.0, 1.0), st.v_body, st.w_body)
        base = Base.__new__(Base)  # no body: frame_pose of a given state needs the frames only
        base._flat_frames = flat_frames({"mount": (rel_pos, rel_rot)})
        pos, rot = base.frame_pose("mount", st)
        want_pos, want_rot = np.asarray(st.xyz) + st.rotation @ rel_pos, st.rotation @ rel_rot
        assert pos.tobytes() == want_pos.tobytes() and rot.tobytes() == want_rot.tobytes()
