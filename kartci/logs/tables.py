"""Turn a log into one pandas table per topic, for the message types metrics and plots use."""

from __future__ import annotations

import math
import stat
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from kartci.core import ROBOTS, Flattener, fields
from kartci.errors import LogError
from kartci.logs.bulk import bulk_table, standard
from kartci.logs.reader import LogReader, Raw, open_log
from kartci.logs.types import stamp_ns, yaw_of, yaws_from

Row = dict[str, Any]


def _yaw(q: Any) -> Any:
    """yaw_of, also of columns (kartci.logs.bulk): libm's atan2 on numpy's same arithmetic."""
    if not isinstance(q.x, np.ndarray):
        return yaw_of(q)
    num, den = 2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z)
    return np.fromiter(map(math.atan2, num.tolist(), den.tolist()), np.float64, len(num))


def _odometry(m: Any) -> Row:
    p, q = m.pose.pose.position, m.pose.pose.orientation
    tw = m.twist.twist
    return {"x": p.x, "y": p.y, "z": p.z, "yaw": _yaw(q), "qx": q.x, "qy": q.y, "qz": q.z,
            "qw": q.w, "vx": tw.linear.x, "vy": tw.linear.y, "wz": tw.angular.z}


def _joint_state(m: Any) -> Row:
    row: Row = {}
    for i, name in enumerate(m.name):
        if i < len(m.velocity):
            row[f"{name}.velocity"] = m.velocity[i]
        if i < len(m.position):
            row[f"{name}.position"] = m.position[i]
    return row


def _listed(values: list[Any]) -> Any:
    """`values`; of columns (kartci.logs.bulk), one list of Python floats per row."""
    if not values or not isinstance(values[0], np.ndarray):
        return values
    out = np.empty(len(values[0]), object)
    for i, row in enumerate(np.stack(values, axis=1).tolist()):
        out[i] = row
    return out


FLATTENERS: dict[str, Flattener] = {
    "nav_msgs/msg/Odometry": _odometry,
    "sensor_msgs/msg/JointState": _joint_state,
    "sensor_msgs/msg/Range": fields("range"),
    "std_msgs/msg/String": fields("data"),
    "std_msgs/msg/UInt32": fields("data"),  # counters (the bridge's late_commands)
    "sensor_msgs/msg/Joy": lambda m: {"axes": m.axes.tolist(), "buttons": m.buttons.tolist()},
    "kartci_msgs/msg/Collision": lambda m: {"other": m.other, "impulse_ns": m.impulse_ns,
                                            "duration_s": m.duration_s, "x": m.position.x,
                                            "y": m.position.y},
    "nav_msgs/msg/Path": lambda m: {"xs": _listed([p.pose.position.x for p in m.poses]),
                                    "ys": _listed([p.pose.position.y for p in m.poses])},
    "sensor_msgs/msg/Imu": lambda m: {"ax": m.linear_acceleration.x,
                                      "ay": m.linear_acceleration.y,
                                      "az": m.linear_acceleration.z, "wz": m.angular_velocity.z},
}
# not decoded in bulk (kartci.logs.bulk): few, or strings that change from message to message
NOT_BULK = frozenset({"sensor_msgs/msg/Joy", "std_msgs/msg/String"})


def flatteners() -> dict[str, Flattener]:
    """The flattener of every message type a table is made of: the standard types above and
    each registered robot kind's own messages (`RobotKind.flatteners`), as rosbags' typestore
    takes types: they register, the reader stays generic."""
    out = dict(FLATTENERS)
    for kind in ROBOTS.all():
        for msgtype, flat in kind.flatteners.items():
            out.setdefault(msgtype, flat)
    return out


def bulk_types(flat: Mapping[str, Flattener]) -> frozenset[str]:
    """The types of `flat` decoded in bulk (kartci.logs.bulk)."""
    return frozenset(flat) - NOT_BULK


def _row(path: Path, topic: str, t_ns: int, m: Any, flat: Flattener) -> Row:
    """A foreign log may define a type of the same name with other fields; say so in one line
    instead of failing in a flattener."""
    try:
        hdr = getattr(m, "header", None)
        t = stamp_ns(hdr) if hdr is not None else t_ns
        return {"t": t * 1e-9, **flat(m)}
    except (AttributeError, TypeError, ValueError) as err:
        raise LogError(f"{path}: {topic} ({m.__msgtype__}) lacks the fields kartci reads from "
                       f"that type ({err})") from err


_File = tuple[int, int, int, int]  # device, inode, size, mtime: a log is written once, by rename
_LAST: dict[_File, tuple[frozenset[str] | None, dict[str, pd.DataFrame]]] = {}


def tables(path: Path, wanted: Sequence[str] | None = None) -> dict[str, pd.DataFrame]:
    """`t` (s, from the header stamp when there is one, else log time) plus flattened fields,
    for the wanted topics (default: every topic of a type in `flatteners()`; the others, tf and
    point clouds, are not decoded at all).

    A run is scored, then judged and drawn, each reading its log: the last log file read in
    full is kept and handed out again as copies (a subset for `wanted`), so a job decodes its
    log once."""
    key = _identity(path)
    want = None if wanted is None else frozenset(wanted)
    if key is not None and key in _LAST:
        have, read = _LAST[key]
        if have is None or have == want:
            return {t: df.copy() for t, df in read.items() if want is None or t in want}
    read = _read(path, wanted)
    if key is not None and want is None:
        _LAST.clear()
        _LAST[key] = (None, read)
        return {t: df.copy() for t, df in read.items()}
    return read


def _identity(path: Path) -> _File | None:
    """A regular file's identity; None for a folder (a rosbag2 folder can change inside)."""
    try:
        st = path.stat()
    except OSError:
        return None  # open_log names the problem
    if not stat.S_ISREG(st.st_mode):
        return None
    return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns


def _read(path: Path, wanted: Sequence[str] | None) -> dict[str, pd.DataFrame]:
    """tables_of(log.messages(wanted)), with the topics of `bulk_types` that the log defines as
    kartci does held back and decoded in bulk (message by message where that fails)."""
    flat_of = flatteners()
    bulk_of = bulk_types(flat_of)
    with open_log(path) as log:
        if wanted is None:
            wanted = [t.topic for t in log.topics() if t.msgtype in flat_of]
        rows: dict[str, list[Row]] = defaultdict(list)
        first: dict[str, int] = {}  # a topic's first row: the tables' order
        held: dict[str, list[tuple[int, Raw]]] = defaultdict(list)
        bulk: dict[str, bool] = {}
        for k, raw in enumerate(log.raw(wanted)):
            msgtype = raw[1]
            if msgtype in bulk_of and msgtype not in bulk:
                bulk[msgtype] = standard(log.typestore, msgtype)
            if not raw[2] and bulk.get(msgtype, False):
                held[raw[0]].append((k, raw))
                continue
            m = log.decode(raw)
            flat = None if m is None else flat_of.get(m.__msgtype__)
            if flat is not None:
                first.setdefault(raw[0], k)
                rows[raw[0]].append(_row(path, raw[0], raw[3], m, flat))
        read = {topic: pd.DataFrame(r) for topic, r in rows.items()}
        for topic, raws in held.items():
            table, k = _held(path, log, raws, flat_of[raws[0][1][1]])
            if table is not None:
                read[topic], first[topic] = table, k
        log.report_undecodable()
    return {topic: read[topic] for topic in sorted(read, key=first.__getitem__)}


def _held(path: Path, log: LogReader, held: list[tuple[int, Raw]], flat: Flattener
          ) -> tuple[pd.DataFrame | None, int]:
    """One held topic's table (None: none of its messages decodes) and its first row's index
    in the log."""
    topic, msgtype = held[0][1][0], held[0][1][1]
    decoded: dict[int, Any] = {}

    def message(i: int) -> Any:
        if i not in decoded:
            decoded[i] = log.decode(held[i][1])
        return decoded[i]

    def reference(i: int) -> tuple[Any, Row] | None:
        m = message(i)
        return None if m is None else (m, _row(path, topic, held[i][1][3], m, flat))

    t_log = np.array([raw[3] for _, raw in held], np.int64)
    table = bulk_table(log.typestore, msgtype, [raw[4] for _, raw in held], t_log, reference,
                       flat)
    if table is not None:
        return table, held[0][0]
    found = [(k, raw, m) for i, (k, raw) in enumerate(held) if (m := message(i)) is not None]
    if not found:
        return None, 0
    return (pd.DataFrame([_row(path, topic, raw[3], m, flat) for _, raw, m in found]),
            found[0][0])


def tables_of(path: Path, messages: Iterable[tuple[str, int, Any]]) -> dict[str, pd.DataFrame]:
    """The tables of (topic, log time ns, message) in log order, as tables() makes them."""
    rows: dict[str, list[Row]] = defaultdict(list)
    flat_of = flatteners()
    for topic, t_ns, m in messages:
        flat = flat_of.get(m.__msgtype__)
        if flat is not None:
            rows[topic].append(_row(path, topic, t_ns, m, flat))
    return {topic: pd.DataFrame(r) for topic, r in rows.items()}


def odometry_table(stamp_ns: np.ndarray, xyz: np.ndarray, quat: np.ndarray,
                   twist: np.ndarray) -> pd.DataFrame:
    """The table of nav_msgs/Odometry messages given as arrays (header stamp ns, position,
    quaternion x y z w, body twist vx vy vz wx wy wz), equal to the one their messages make."""
    return pd.DataFrame({
        "t": stamp_ns.astype(np.float64) * 1e-9, "x": xyz[:, 0], "y": xyz[:, 1],
        "z": xyz[:, 2], "yaw": yaws_from(quat), "qx": quat[:, 0],
        "qy": quat[:, 1], "qz": quat[:, 2], "qw": quat[:, 3], "vx": twist[:, 0],
        "vy": twist[:, 1], "wz": twist[:, 5]})


def remember(path: Path, read: dict[str, pd.DataFrame]) -> None:
    """Hand out `read` as the tables of the log just written to `path` (whoever wrote it
    knows them: a long imported log is then not decoded again to be scored)."""
    key = _identity(path)
    if key is not None:
        _LAST.clear()
        _LAST[key] = (None, read)
