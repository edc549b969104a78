"""Planar poses as pose sources: turtlesim's Pose (x, y, theta, linear and angular velocity)
and geometry_msgs/Pose2D, in logs written here (rosbag2 MCAP and ROS 1), scored as any pose."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from helpers import kartci
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from kartci.logs import topics
from kartci.realdata.profile import auto_profile

TURTLE = "turtlesim/msg/Pose"
TURTLE_MSG = ("float32 x\nfloat32 y\nfloat32 theta\n\nfloat32 linear_velocity\n"
              "float32 angular_velocity\n")
V, W, N, HZ = 0.5, 0.5, 200, 20  # a turtle on a circle of 1 m radius, 10 s at 20 Hz


def _turtle(k: int) -> tuple[float, float, float]:
    th = W * k / HZ
    return 5.0 + math.sin(th), 5.0 + 1.0 - math.cos(th), th


def _write(path: Path, ros1: bool) -> None:
    """The turtle's /turtle1/pose and a Pose2D estimate 0.1 m beside it, on log time."""
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg(TURTLE_MSG, TURTLE))
    pose_t, est_t = TURTLE, "geometry_msgs/msg/Pose2D"
    writer = Writer1(path) if ros1 else Writer(path, version=8,
                                                storage_plugin=StoragePlugin.MCAP)
    ser = store.serialize_ros1 if ros1 else store.serialize_cdr
    with writer as w:
        pose, est = (w.add_connection(t, m, typestore=store)
                     for t, m in (("/turtle1/pose", pose_t), ("/estimate", est_t)))
        for k in range(N):
            x, y, th = _turtle(k)
            ns = 3 * 10**9 + k * 10**9 // HZ
            m = store.types[pose_t](x=x, y=y, theta=th, linear_velocity=V, angular_velocity=W)
            w.write(pose, ns, ser(m, pose_t))
            e = store.types[est_t](x=x + 0.1, y=y, theta=th)
            w.write(est, ns, ser(e, est_t))


@pytest.mark.parametrize("ros1", [False, True], ids=["rosbag2", "ros1"])
def test_a_turtlesim_pose_is_scored(tmp_path: Path, ros1: bool) -> None:
    log = tmp_path / ("turtle.bag" if ros1 else "turtle")
    _write(log, ros1)
    profile = tmp_path / "turtle.yaml"
    profile.write_text("name: turtle\npose: {topic: /turtle1/pose}\n"
                       "estimate: {topic: /estimate}\n")
    out = tmp_path / "out"
    (tmp_path / "bl").mkdir()
    r = kartci("score", log, "-p", profile, "--out", out, "--baselines", tmp_path / "bl",
               "--no-html")
    assert r.returncode == 0, r.stderr
    assert "warning" not in r.stderr  # no header, no frame: nothing to warn about
    doc = json.loads((out / "turtle" / "metrics.json").read_text(encoding="utf-8"))
    m = {k: v["value"] for k, v in doc["metrics"].items()}
    xy = np.array([_turtle(k)[:2] for k in range(N)], np.float32).astype(float)
    assert m["duration_s"] == pytest.approx((N - 1) / HZ)  # log time: no header stamps
    assert m["distance_m"] == pytest.approx(np.sum(np.hypot(*np.diff(xy, axis=0).T)),
                                            rel=1e-4)
    # speeds and yaw rate are the message's own velocities
    assert m["max_speed_mps"] == pytest.approx(V) and m["mean_speed_mps"] == pytest.approx(V)
    assert m["max_yaw_rate_radps"] == pytest.approx(W)
    # the Pose2D estimate 0.1 m off in x: APE 0.1 m (float32 fields)
    assert m["ape_rmse_m"] == pytest.approx(0.1, abs=1e-5)


def test_a_log_with_only_a_turtle_needs_no_profile(tmp_path: Path) -> None:
    log = tmp_path / "turtle"
    _write(log, ros1=False)
    info = [i for i in topics(log) if i.topic != "/estimate"]
    assert auto_profile(log, info).pose.topic == "/turtle1/pose"
