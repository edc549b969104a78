"""One time base in an imported log's reports: seconds since the log's start, its absolute start
said once (in the recorded scenario's description), whatever clock the log's stamps are on."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from helpers import kartci
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from kartci.logs import tables

START_S = 1_700_000_000  # 2023-11-14T22:13:20Z


def _log(path: Path) -> None:
    """10 s at 20 Hz: AMCL and odometry agree, except odometry 0.5 m off from 5 s to 6 s."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = {"map": w.add_connection("/amcl_pose",
                                         "geometry_msgs/msg/PoseWithCovarianceStamped",
                                         typestore=store),
                 "odom": w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=store)}
        for k in range(200):
            ns = START_S * 10**9 + k * 50_000_000
            for frame, conn in conns.items():
                x = 0.1 * k * 0.05 + (0.5 if frame == "odom" and 100 <= k < 120 else 0.0)
                hdr = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](
                    sec=ns // 10**9, nanosec=ns % 10**9), frame_id="map")
                pose = t["geometry_msgs/msg/PoseWithCovariance"](
                    pose=t["geometry_msgs/msg/Pose"](
                        position=t["geometry_msgs/msg/Point"](x=x, y=0.0, z=0.0),
                        orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0,
                                                                      w=1.0)),
                    covariance=np.zeros(36))
                if frame == "map":
                    m = t["geometry_msgs/msg/PoseWithCovarianceStamped"](header=hdr, pose=pose)
                else:
                    zero = t["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
                    m = t["nav_msgs/msg/Odometry"](
                        header=hdr, child_frame_id="base_link", pose=pose,
                        twist=t["geometry_msgs/msg/TwistWithCovariance"](
                            twist=t["geometry_msgs/msg/Twist"](linear=zero, angular=zero),
                            covariance=np.zeros(36)))
                w.write(conn, ns, store.serialize_cdr(m, m.__msgtype__))


@pytest.mark.long(reason="end-to-end runs of real or synthetic logs")
def test_reports_count_seconds_from_the_log_start_and_say_it_once(tmp_path: Path) -> None:
    log = tmp_path / "wall"
    _log(log)
    profile = tmp_path / "p.yaml"
    profile.write_text("name: wall\npose: {topic: /amcl_pose}\nestimate: {topic: /odom}\n")
    out = tmp_path / "out"
    r = kartci("score", log, "--profile", profile, "--out", out)
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "wall" / "metrics.json").read_text(encoding="utf-8"))
    m = doc["metrics"]
    assert m["duration_s"]["value"] == pytest.approx(9.95)
    (event,) = m["divergence_events"]["events"]
    assert event["t_s"] == pytest.approx(5.0)  # not 1,700,000,005
    odom = tables(out / "wall" / "run.mcap")["/robot/odom"]
    assert odom["t"].iloc[0] == 0.0 and odom["t"].iloc[-1] == pytest.approx(9.95)
    scenario = tables(out / "wall" / "run.mcap")["/kartci/scenario"]["data"].iloc[0]
    assert json.loads(scenario)["description"] == (
        "imported log (wall); t = 0 s is 2023-11-14T22:13:20.000Z")
