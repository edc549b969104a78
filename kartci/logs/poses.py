"""Pose streams in bulk: Odometry, PoseStamped and PoseWithCovarianceStamped read straight from
their CDR bytes into numpy arrays, and Odometry written back the same way; planar poses
(turtlesim's Pose, Pose2D) mapped onto the same arrays.

A long log holds tens of thousands of poses; decoding each into a message object, and building
and serialising one per output message, was most of `kartci score`'s time. CDR lays these
types out at fixed offsets once the header's frame names are known, so messages with the same
frame names and length are decoded together as one array. Anything else (ROS 1 encoding, big
endian, a log that defines the type differently, bytes of an unexpected length) goes through
rosbags' own decoder, message by message: the numbers are the same either way.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from rosbags.typesys.store import Typestore

from kartci.logs.bulk import standard
from kartci.logs.reader import Raw
from kartci.logs.types import stamp_ns, yaws_from

ODOMETRY = "nav_msgs/msg/Odometry"
LAID_OUT = (ODOMETRY, "geometry_msgs/msg/PoseStamped",
            "geometry_msgs/msg/PoseWithCovarianceStamped")  # decoded in bulk
# planar poses without a header (stamped by log time, no frame): their fields x, y, heading
# (rad) and, where the type has them, forward speed (m/s) and yaw rate (rad/s)
PLANAR = {"turtlesim/msg/Pose": ("x", "y", "theta", "linear_velocity", "angular_velocity"),
          "geometry_msgs/msg/Pose2D": ("x", "y", "theta", None, None)}
POSE_TYPES = (*LAID_OUT, *PLANAR)
_CDR_LE = b"\x00\x01"  # encapsulation: plain CDR, little endian
_COV = 36  # doubles in a covariance matrix


@dataclass(frozen=True)
class Poses:
    """One pose stream in log order. `stamp`: header stamp (ns; 0 when unset); `twist`: the
    message's body twist (vx, vy, vz, wx, wy, wz; Odometry only); `frames`: the header frames
    met, in order of first appearance (frames[0] is the first message's)."""

    t_log: np.ndarray  # log time, ns (int64)
    stamp: np.ndarray  # ns (int64)
    xyz: np.ndarray  # (n, 3) m
    quat: np.ndarray  # (n, 4) x, y, z, w
    twist: np.ndarray | None  # (n, 6) m/s, rad/s
    frames: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.t_log)

    def times(self) -> np.ndarray:
        """The header stamp where set, else the log time (ns)."""
        return np.where(self.stamp > 0, self.stamp, self.t_log)


def _align(pos: int, size: int) -> int:
    return (pos + size - 1) // size * size


def _string_end(body: bytes, pos: int) -> tuple[int, bytes]:
    """The end of the CDR string at `pos` (aligned to 4) and its bytes."""
    pos = _align(pos, 4)
    n = int.from_bytes(body[pos:pos + 4], "little")
    return pos + 4 + n, body[pos + 4:pos + 4 + n]


def _layout(msgtype: str, body: bytes) -> tuple[tuple[int, bytes, bytes], int] | None:
    """(key, offset of the pose's doubles in the body), key = (length, frame, child frame);
    None when the bytes cannot be this type's standard layout."""
    if len(body) < 12:
        return None
    end, frame = _string_end(body, 8)
    child = b""
    if msgtype == ODOMETRY:
        end, child = _string_end(body, end)
    start = _align(end, 8)
    doubles = 7 + {ODOMETRY: 2 * _COV + 6, LAID_OUT[1]: 0, LAID_OUT[2]: _COV}[msgtype]
    if start + 8 * doubles != len(body) or not frame.endswith(b"\x00"):
        return None
    return (len(body), frame, child), start


def _columns(rows: np.ndarray, start: int, count: int, dtype: str) -> np.ndarray:
    """`count` little-endian values of `dtype` at byte `start` of each row."""
    size = np.dtype(dtype).itemsize
    return rows[:, start:start + size * count].copy().view(dtype)


def same_definitions(store: Typestore, msgtype: str) -> bool:
    """Whether `msgtype` is decoded in bulk: one of LAID_OUT, which `store` defines as kartci's
    standard store does (else the bytes are decoded by the log's own definition, one by
    one)."""
    return msgtype in LAID_OUT and standard(store, msgtype)


def decode_poses(raws: Sequence[Raw], standard: bool, decode: Callable[[Raw], Any]) -> Poses:
    """The pose stream of `raws` (one topic, one type): bulk where the bytes are standard CDR
    (`standard`: the log defines the type as kartci does), else `decode(raw)` per message
    (None: skipped, as the reader's messages() skips it)."""
    msgtype = raws[0][1] if raws else LAID_OUT[1]
    groups: dict[tuple[int, bytes, bytes], tuple[int, list[int]]] = {}
    single: list[tuple[int, Any]] = []
    # the last layout met: message length, its frame names' bytes (all _layout reads but the
    # length), its rows; a message with the same length and bytes there has that layout too
    last: tuple[int, bytes, list[int]] = (-1, b"", [])
    for i, raw in enumerate(raws):
        data = raw[4]
        if (len(data) == last[0] and data[12:12 + len(last[1])] == last[1] and not raw[2]
                and data[:2] == _CDR_LE):
            last[2].append(i)
            continue
        found = (_layout(msgtype, data[4:]) if standard and not raw[2]
                 and data[:2] == _CDR_LE else None)
        if found is None:
            single.append((i, decode(raw)))
        else:
            members = groups.setdefault(found[0], (found[1], []))[1]
            members.append(i)
            last = (len(data), bytes(data[12:4 + found[1]]), members)
    n = len(raws)
    keep = np.ones(n, bool)
    stamp, xyz, quat = np.zeros(n, np.int64), np.zeros((n, 3)), np.zeros((n, 4))
    has_twist = msgtype == ODOMETRY or PLANAR.get(msgtype, (None,) * 5)[3] is not None
    twist = np.zeros((n, 6)) if has_twist else None
    frame_of: dict[int, str] = {}
    for (length, frame, _), (start, idx) in groups.items():
        rows = np.frombuffer(b"".join([raws[i][4][4:] for i in idx]), np.uint8).reshape(-1,
                                                                                       length)
        sec, nsec = _columns(rows, 0, 1, "<i4")[:, 0], _columns(rows, 4, 1, "<u4")[:, 0]
        stamp[idx] = sec.astype(np.int64) * 1_000_000_000 + nsec.astype(np.int64)
        pose = _columns(rows, start, 7, "<f8")
        xyz[idx], quat[idx] = pose[:, :3], pose[:, 3:]
        if twist is not None:
            twist[idx] = _columns(rows, start + 8 * (7 + _COV), 6, "<f8")
        name = frame[:-1].decode("utf-8", "replace")
        frame_of.update(dict.fromkeys(idx, name))
    for i, m in single:
        if m is None:
            keep[i] = False
            continue
        if msgtype in PLANAR:
            _fill_planar(m, PLANAR[msgtype], i, xyz, quat, twist)
            continue
        _fill(m, i, stamp, xyz, quat, twist)
        frame_of[i] = str(getattr(m.header, "frame_id", "") or "")
    t_log = np.array([raw[3] for raw in raws], np.int64)
    frames = tuple(dict.fromkeys(frame_of[i] for i in range(n) if keep[i] and i in frame_of))
    return Poses(t_log[keep], stamp[keep], xyz[keep], quat[keep],
                 None if twist is None else twist[keep], frames)


def _fill(m: Any, i: int, stamp: np.ndarray, xyz: np.ndarray, quat: np.ndarray,
          twist: np.ndarray | None) -> None:
    """Row `i` from a decoded message (its header stamp, pose and, for Odometry, twist)."""
    stamp[i] = stamp_ns(m.header)
    p = m.pose.pose if hasattr(m.pose, "pose") else m.pose
    xyz[i] = p.position.x, p.position.y, p.position.z
    quat[i] = p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w
    if twist is not None:
        lin, ang = m.twist.twist.linear, m.twist.twist.angular
        twist[i] = lin.x, lin.y, lin.z, ang.x, ang.y, ang.z


def _fill_planar(m: Any, fields: tuple[str | None, ...], i: int, xyz: np.ndarray,
                 quat: np.ndarray, twist: np.ndarray | None) -> None:
    """Row `i` from a planar pose (PLANAR's fields): z 0, the heading as a rotation about z."""
    x, y, yaw, v, w = (float(getattr(m, f)) if f else 0.0 for f in fields)
    xyz[i] = x, y, 0.0
    quat[i] = 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)
    if twist is not None:
        twist[i] = v, 0.0, 0.0, 0.0, 0.0, w


def body_twist(t_ns: np.ndarray, xyz: np.ndarray, quat: np.ndarray) -> np.ndarray:
    """The body-frame twist of a pose stream without one, from finite differences of the poses
    (numpy.gradient; the heading unwrapped), (n, 6)."""
    yaw = np.unwrap(yaws_from(quat))
    t_s = (t_ns - t_ns[0]) * 1e-9
    out = np.zeros((len(t_ns), 6))
    if len(t_ns) < 2 or float(t_s[-1]) <= 0:
        return out
    vel = np.gradient(xyz, t_s, axis=0)
    wz = np.gradient(yaw, t_s)
    for i, (vx, vy, vz) in enumerate(vel.tolist()):
        c, s = math.cos(yaw[i]), math.sin(yaw[i])
        out[i] = c * vx + s * vy, -s * vx + c * vy, vz, 0.0, 0.0, float(wz[i])
    return out


def _cdr_string(text: str) -> bytes:
    """A CDR string (its length, UTF-8 bytes and NUL)."""
    raw = text.encode() + b"\x00"
    return len(raw).to_bytes(4, "little") + raw


def odometry_cdr(stamp: np.ndarray, frame: str, child: str, xyz: np.ndarray, quat: np.ndarray,
                 twist: np.ndarray) -> list[bytes]:
    """nav_msgs/Odometry messages as CDR, zero covariances: the bytes rosbags' serialize_cdr
    writes for the same message (tests/logs/test_poses.py compares them)."""
    head = _cdr_string(frame)
    pos = 8 + len(head)
    pad = _align(pos, 4) - pos
    child_raw = b"\x00" * pad + _cdr_string(child)
    pos += len(child_raw)
    tail_pad = _align(pos, 8) - pos
    n = len(stamp)
    fixed = 8 + len(head) + len(child_raw) + tail_pad
    rows = np.zeros((n, 4 + fixed + 8 * (2 * (7 + 36) - 1)), np.uint8)
    rows[:, 1] = 1  # CDR, little endian
    sec, nsec = np.divmod(stamp.astype(np.int64), 1_000_000_000)
    rows[:, 4:8] = sec.astype("<i4").view(np.uint8).reshape(n, 4)
    rows[:, 8:12] = nsec.astype("<u4").view(np.uint8).reshape(n, 4)
    prefix = np.frombuffer(head + child_raw + b"\x00" * tail_pad, np.uint8)
    rows[:, 12:4 + fixed] = prefix
    start = 4 + fixed
    pose = np.ascontiguousarray(np.hstack([xyz, quat]), "<f8")
    rows[:, start:start + 56] = pose.view(np.uint8).reshape(n, 56)
    at = start + 8 * (7 + _COV)
    rows[:, at:at + 48] = np.ascontiguousarray(twist, "<f8").view(np.uint8).reshape(n, 48)
    return [row.tobytes() for row in rows]


__all__ = ["LAID_OUT", "ODOMETRY", "PLANAR", "POSE_TYPES", "Poses", "body_twist", "decode_poses",
           "odometry_cdr", "same_definitions"]
