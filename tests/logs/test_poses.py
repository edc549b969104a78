"""Pose streams in bulk (kartci.logs.poses): the numbers and bytes rosbags' per-message decoder
and serialiser give, on logs written here with rosbags; and an imported log's tables handed to
scoring equal to those read back from the file."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from kartci.logs import SalvagedLog, open_log, tables
from kartci.logs.poses import LAID_OUT, decode_poses, odometry_cdr, same_definitions
from kartci.logs.tables import _read
from kartci.project import current as active_project
from kartci.realdata.importer import import_log
from kartci.realdata.profile import resolve_profile

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types


def _pose(rng: np.random.Generator, k: int, frame: str, stamp_ns: int, msgtype: str) -> Any:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    header = T["std_msgs/msg/Header"](
        stamp=T["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9),
        frame_id=frame)
    pose = T["geometry_msgs/msg/Pose"](
        position=T["geometry_msgs/msg/Point"](x=float(k), y=rng.normal(), z=rng.normal()),
        orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))
    cov = T["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=rng.normal(size=36))
    if msgtype == "geometry_msgs/msg/PoseStamped":
        return T[msgtype](header=header, pose=pose)
    if msgtype == "geometry_msgs/msg/PoseWithCovarianceStamped":
        return T[msgtype](header=header, pose=cov)
    vec = T["geometry_msgs/msg/Vector3"]
    twist = T["geometry_msgs/msg/Twist"](linear=vec(x=rng.normal(), y=rng.normal(), z=0.5),
                                         angular=vec(x=0.0, y=0.1, z=rng.normal()))
    child = "base_footprint" if k // 6 % 2 else "b"
    return T[msgtype](header=header, child_frame_id=child, pose=cov,
                      twist=T["geometry_msgs/msg/TwistWithCovariance"](
                          twist=twist, covariance=np.zeros(36)))


def _write(path: Path) -> dict[str, list[Any]]:
    """One topic of each pose type; frames of several lengths (the CDR padding moves), some
    stamps unset; runs of messages with the same frames (read by the layout of the first)."""
    rng = np.random.default_rng(4)
    written: dict[str, list[Any]] = {}
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        for i, msgtype in enumerate(LAID_OUT):
            conn = w.add_connection(f"/p{i}", msgtype, typestore=STORE)
            written[conn.topic] = []
            for k in range(60):
                stamp = 0 if k % 11 == 0 else 7 * 10**9 + k * 12_345_678
                m = _pose(rng, k, ("map", "odom", "a/long_frame")[k // 4 % 3], stamp, msgtype)
                w.write(conn, 10**9 + k * 10**7 + i, STORE.serialize_cdr(m, msgtype))
                written[conn.topic].append(m)
    return written


@pytest.mark.parametrize("msgtype", LAID_OUT)
def test_bulk_decoding_gives_what_rosbags_decodes(tmp_path: Path, msgtype: str) -> None:
    written = _write(tmp_path / "log")
    topic = f"/p{LAID_OUT.index(msgtype)}"
    with open_log(tmp_path / "log") as log:
        raws = list(log.raw([topic]))
        assert same_definitions(log.typestore, msgtype)
        fast = decode_poses(raws, True, log.decode)
        slow = decode_poses(raws, False, log.decode)  # rosbags, message by message
    assert len(fast) == len(slow) == 60
    for a, b in ((fast.t_log, slow.t_log), (fast.stamp, slow.stamp), (fast.xyz, slow.xyz),
                 (fast.quat, slow.quat)):
        assert a.tobytes() == b.tobytes()
    assert (fast.twist is None) == (slow.twist is None) == (msgtype != LAID_OUT[0])
    if fast.twist is not None and slow.twist is not None:
        assert fast.twist.tobytes() == slow.twist.tobytes()
    assert fast.frames == slow.frames == ("map", "odom", "a/long_frame")
    m = written[topic][5]
    p = m.pose.pose if hasattr(m.pose, "pose") else m.pose
    assert fast.xyz[5].tolist() == [p.position.x, p.position.y, p.position.z]
    assert fast.stamp[0] == 0 and fast.times()[0] == fast.t_log[0]


def test_bytes_that_are_not_the_layout_are_decoded_one_by_one(tmp_path: Path) -> None:
    _write(tmp_path / "log")
    with open_log(tmp_path / "log") as log:
        raws = list(log.raw(["/p1"]))
        cut = [*raws[:3], (*raws[3][:4], raws[3][4][:-8]), *raws[4:]]  # one message 8 bytes short
        got = decode_poses(cut, True, log.decode)
        with pytest.warns(SalvagedLog):
            log.report_undecodable()
        assert len(got) == 59  # the short one does not decode: skipped, as messages() skips it
        assert any("skipped messages that do not decode: 1 on /p1" in n for n in log.notes)


@pytest.mark.parametrize(("frame", "child"), [("map", "base_link"), ("odom", "b"), ("", "x/y/z")])
def test_odometry_bytes_are_rosbags_own(frame: str, child: str) -> None:
    rng = np.random.default_rng(1)
    n = 5
    stamp = np.array([0, 1, 10**9 - 1, 10**9, 1234 * 10**9 + 5], np.int64)
    xyz, quat, twist = rng.normal(size=(n, 3)), rng.normal(size=(n, 4)), rng.normal(size=(n, 6))
    ours = odometry_cdr(stamp, frame, child, xyz, quat, twist)
    zeros = np.zeros(36)
    vec = T["geometry_msgs/msg/Vector3"]
    for i in range(n):
        sec, nsec = divmod(int(stamp[i]), 10**9)
        m = T["nav_msgs/msg/Odometry"](
            header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
                sec=sec, nanosec=nsec), frame_id=frame), child_frame_id=child,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=T["geometry_msgs/msg/Pose"](
                position=T["geometry_msgs/msg/Point"](x=xyz[i, 0], y=xyz[i, 1], z=xyz[i, 2]),
                orientation=T["geometry_msgs/msg/Quaternion"](
                    x=quat[i, 0], y=quat[i, 1], z=quat[i, 2], w=quat[i, 3])), covariance=zeros),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=T["geometry_msgs/msg/Twist"](
                linear=vec(x=twist[i, 0], y=twist[i, 1], z=twist[i, 2]),
                angular=vec(x=twist[i, 3], y=twist[i, 4], z=twist[i, 5])), covariance=zeros))
        assert ours[i] == bytes(STORE.serialize_cdr(m, "nav_msgs/msg/Odometry"))


@pytest.mark.parametrize(("ref", "est"), [("/p2", "/p0"), ("/p0", "/p1")])
def test_an_imported_logs_tables_equal_those_read_back(tmp_path: Path, ref: str,
                                                       est: str) -> None:
    """Scoring takes the tables the import made; they are the file's, to the bit."""
    _write(tmp_path / "log")
    profile = tmp_path / "p.yaml"
    profile.write_text(f"name: p\npose: {{topic: {ref}}}\nestimate: {{topic: {est}}}\n")
    prof, info = resolve_profile(tmp_path / "log", profile, active_project())
    dst = tmp_path / "run.mcap"
    import_log(tmp_path / "log", prof, {r: i.msgtype for r, i in info.items()}, dst)
    handed, read = tables(dst), _read(dst, None)
    assert sorted(handed) == sorted(read)
    for topic, table in read.items():
        pd.testing.assert_frame_equal(handed[topic], table, check_exact=True)
    assert len(read["/robot/estimate"]) == 60
