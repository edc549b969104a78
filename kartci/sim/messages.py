"""Building the ROS 2 messages the simulator publishes."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from kartci.logs import header, typestore
from kartci.logs.types import WORLD_FRAME as WORLD_FRAME  # re-exported for the sim
from kartci.sim.body import BodyState

# Messages are built by their classes, fields in the .msg's order: the loop makes about 40 a
# kart's odometry tick, and `msg`'s keywords cost twice the object.
_VECTOR3 = "geometry_msgs/msg/Vector3"
_QUATERNION = "geometry_msgs/msg/Quaternion"


def vec(x: float, y: float, z: float) -> Any:
    """A geometry_msgs/Vector3."""
    return typestore().types[_VECTOR3](x, y, z)


def quat_msg(q: Any) -> Any:
    """A geometry_msgs/Quaternion from (x, y, z, w)."""
    return typestore().types[_QUATERNION](q[0], q[1], q[2], q[3])


def pose(xyz: Any, q: Any) -> Any:
    """A geometry_msgs/Pose from a position (m) and a quaternion (x, y, z, w)."""
    types = typestore().types
    return types["geometry_msgs/msg/Pose"](
        types["geometry_msgs/msg/Point"](xyz[0], xyz[1], xyz[2]),
        types[_QUATERNION](q[0], q[1], q[2], q[3]))


def transform(t_ns: int, parent: str, child: str, xyz: Any, q: Any) -> Any:
    """A geometry_msgs/TransformStamped of frame `child` in `parent` at `t_ns`."""
    stamped, tr, vector3, quaternion = _transform_types()
    return stamped(header(t_ns, parent), child, tr(vector3(xyz[0], xyz[1], xyz[2]),
                                                   quaternion(q[0], q[1], q[2], q[3])))


@functools.cache
def _transform_types() -> tuple[Any, Any, Any, Any]:
    """The classes a transform is made of, looked up once (a kart's odometry tick makes 7)."""
    types = typestore().types
    return (types["geometry_msgs/msg/TransformStamped"], types["geometry_msgs/msg/Transform"],
            types[_VECTOR3], types[_QUATERNION])


def quat_from_matrix(r: np.ndarray) -> tuple[float, float, float, float]:
    """The quaternion (x, y, z, w) of a 3x3 rotation matrix."""
    w = math.sqrt(max(0.0, 1 + r[0, 0] + r[1, 1] + r[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1 + r[0, 0] - r[1, 1] - r[2, 2])) / 2, r[2, 1] - r[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1 - r[0, 0] + r[1, 1] - r[2, 2])) / 2, r[0, 2] - r[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1 - r[0, 0] - r[1, 1] + r[2, 2])) / 2, r[1, 0] - r[0, 1])
    return x, y, z, w


def frozen(a: np.ndarray) -> np.ndarray:
    """An array shared by every message that carries it (covariances built once, not per
    message): read-only, so no reader can change what the others and the log see."""
    a.setflags(write=False)
    return a


ZEROS36 = frozen(np.zeros(36))


def odometry(t_ns: int, ns: str, st: BodyState) -> Any:
    """nav_msgs/Odometry of `<ns>/base_link` in the world frame from ground truth, twist in
    base_link; zero covariances."""
    types = typestore().types
    v, w = st.v_body, st.w_body
    twist = types["geometry_msgs/msg/Twist"](types[_VECTOR3](v[0], v[1], v[2]),
                                             types[_VECTOR3](w[0], w[1], w[2]))
    return types["nav_msgs/msg/Odometry"](
        header(t_ns, WORLD_FRAME), f"{ns}/base_link",
        types["geometry_msgs/msg/PoseWithCovariance"](pose(st.xyz, st.quat), ZEROS36),
        types["geometry_msgs/msg/TwistWithCovariance"](twist, ZEROS36))


def joint_state(t_ns: int, frame: str, names: list[str], position: list[float],
                velocity: list[float]) -> Any:
    """A sensor_msgs/JointState: joint positions (rad) and velocities (rad/s), no efforts."""
    return typestore().types["sensor_msgs/msg/JointState"](
        header(t_ns, frame), names, np.asarray(position, dtype=float),
        np.asarray(velocity, dtype=float), np.zeros(0))


def tf_message(transforms: list[Any]) -> Any:
    """A tf2_msgs/TFMessage, for /tf and /tf_static."""
    return typestore().types["tf2_msgs/msg/TFMessage"](transforms)
