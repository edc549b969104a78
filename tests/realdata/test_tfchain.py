"""A pose source from a TF chain (map -> odom -> base_link through /tf, a static edge through
/tf_static), sampled at the other trajectory's stamps: with motion that interpolation follows
exactly, the chain reproduces the analytic pose, so the APE against a reference offset by a
known 0.1 m is 0.1 m at every stamp."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import kartci
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from scipy.spatial.transform import Rotation

from kartci.errors import SpecError
from kartci.project import current as active_project
from kartci.realdata.profile import load_profile

STORE = get_typestore(Stores.ROS2_HUMBLE)
T = STORE.types
T0_NS = 50 * 10**9


def _odom_base(t: np.ndarray) -> tuple[np.ndarray, Rotation]:
    """odom -> base_link: straight at 0.5 m/s in x, 0.2 m/s in y, turning at 0.1 rad/s."""
    return np.column_stack([0.5 * t, 0.2 * t, 0 * t]), Rotation.from_euler("z", (0.1 * t)[:, None])


def _map_odom(t: np.ndarray) -> tuple[np.ndarray, Rotation]:
    """map -> odom: a fixed 0.3 rad turn and a drift linear in time."""
    return (np.column_stack([1.0 + 0.01 * t, 2.0 - 0.02 * t, 0 * t]),
            Rotation.from_euler("z", (0.3 + 0 * t)[:, None]))


def _stamp(t_s: float) -> Any:
    ns = T0_NS + round(t_s * 1e9)
    return T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)


def _tf(parent: str, child: str, t_s: float, p: np.ndarray, r: Rotation) -> Any:
    q = r.as_quat()
    return T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](stamp=_stamp(t_s), frame_id=parent),
        child_frame_id=child, transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=p[0], y=p[1], z=p[2]),
            rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])))


def _log(path: Path) -> None:
    """/tf: map -> odom at 10 Hz, odom -> base_link at 50 Hz; /tf_static: base_link -> laser;
    /ground_truth: map -> base_link offset 0.1 m along the robot's x, at 20 Hz from 1 s to 9 s
    (stamps between the TF stamps)."""
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        tf = w.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=STORE)
        static = w.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=STORE)
        gt = w.add_connection("/ground_truth", "geometry_msgs/msg/PoseStamped", typestore=STORE)
        items: list[tuple[int, Any, Any]] = []
        laser = _tf("base_link", "laser", 0.0, np.array([0.1, 0.0, 0.0]), Rotation.identity())
        items.append((T0_NS, static, T["tf2_msgs/msg/TFMessage"](transforms=[laser])))
        for t in np.arange(0, 10.0001, 0.1):
            p, r = _map_odom(np.array([t]))
            items.append((T0_NS + round(t * 1e9), tf, T["tf2_msgs/msg/TFMessage"](
                transforms=[_tf("map", "odom", t, p[0], r[0])])))
        for t in np.arange(0, 10.0001, 0.02):
            p, r = _odom_base(np.array([t]))
            items.append((T0_NS + round(t * 1e9), tf, T["tf2_msgs/msg/TFMessage"](
                transforms=[_tf("odom", "base_link", t, p[0], r[0])])))
        ts = np.arange(1.0, 9.0, 0.05) + 0.013
        pm, rm = _map_odom(ts)
        pb, rb = _odom_base(ts)
        pos, rot = pm + rm.apply(pb), rm * rb
        pos = pos + rot.apply(np.array([0.1, 0.0, 0.0]))
        for k, t in enumerate(ts):
            q = rot[k].as_quat()
            m = T["geometry_msgs/msg/PoseStamped"](
                header=T["std_msgs/msg/Header"](stamp=_stamp(t), frame_id="map"),
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=pos[k, 0], y=pos[k, 1], z=0.0),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2],
                                                                  w=q[3])))
            items.append((T0_NS + round(t * 1e9), gt, m))
        for t_ns, conn, m in sorted(items, key=lambda x: x[0]):
            w.write(conn, t_ns, STORE.serialize_cdr(m, m.__msgtype__))


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_a_tf_chain_is_scored_as_an_estimate_at_the_reference_stamps(tmp_path: Path) -> None:
    log = tmp_path / "tf_log"
    _log(log)
    profile = tmp_path / "tf.yaml"
    profile.write_text("name: tfchain\npose: {topic: /ground_truth}\n"
                       "estimate: {topic: /tf, parent: map, child: base_link}\n")
    out = tmp_path / "out"
    r = kartci("score", log, "--profile", profile, "--out", out)
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr  # both in map
    doc = json.loads((out / "tfchain" / "metrics.json").read_text(encoding="utf-8"))
    m = {k: v["value"] for k, v in doc["metrics"].items()}
    assert m["ape_rmse_m"] == pytest.approx(0.1, abs=1e-9)
    assert m["ape_max_m"] == pytest.approx(0.1, abs=1e-9)
    assert m["ape_rot_rmse_deg"] == pytest.approx(0.0, abs=1e-6)
    # through the static edge: the laser's pose, 0.1 m ahead of base_link = the reference
    profile.write_text("name: tfchain\npose: {topic: /ground_truth}\n"
                       "estimate: {topic: /tf, parent: map, child: laser}\n")
    assert kartci("score", log, "--profile", profile, "--out", out).returncode == 0
    doc = json.loads((out / "tfchain" / "metrics.json").read_text(encoding="utf-8"))
    assert doc["metrics"]["ape_max_m"]["value"] == pytest.approx(0.0, abs=1e-9)


@pytest.mark.long(reason="end-to-end scoring, calibration or simulation of logs")
def test_a_tf_chain_as_the_reference_at_its_own_stamps_and_errors(tmp_path: Path) -> None:
    log = tmp_path / "tf_log"
    _log(log)
    profile = tmp_path / "tf.yaml"
    profile.write_text("name: tfref\npose: {topic: /tf, parent: odom, child: base_link}\n")
    out = tmp_path / "out"
    r = kartci("score", log, "--profile", profile, "--out", out)
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "tfref" / "metrics.json").read_text(encoding="utf-8"))
    # 0.5 and 0.2 m/s for 10 s, sampled at odom -> base_link's own 50 Hz
    assert doc["metrics"]["distance_m"]["value"] == pytest.approx(np.hypot(5.0, 2.0), rel=1e-6)
    profile.write_text("name: tfref\npose: {topic: /tf, parent: map, child: wheel}\n")
    r = kartci("score", log, "--profile", profile, "--out", out)
    assert r.returncode == 2
    assert r.stderr.strip().endswith("no TF chain from 'map' to 'wheel' in the log (frames: "
                                     "base_link, laser, map, odom)"), r.stderr
    profile.write_text("name: tfref\npose: {topic: /tf}\n")
    r = kartci("score", log, "--profile", profile, "--out", out)
    assert r.returncode == 2 and "with `parent` and `child` frames" in r.stderr, r.stderr


def test_a_tf_pose_names_both_frames(tmp_path: Path) -> None:
    path = tmp_path / "p.yaml"
    path.write_text("pose: {topic: /tf, parent: map}\n")
    with pytest.raises(SpecError, match="both `parent` and `child`"):
        load_profile(path, active_project())
