"""A real robot's bag (the TurtleBot3's LaserScan, IMU and odometry) replayed open loop through
kartci's localization on a map built from its own scans, and scored against its odometry; a
profile that lacks a stream the node reads is one line naming it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from helpers import kartci

BAG = "turtlebot3_gazebo_cmd_odom_scan.bag"


@pytest.mark.long(reason="end-to-end runs of real or synthetic logs")
def test_the_turtlebot_bag_replays_through_localization(bags: Path, tmp_path: Path) -> None:
    profile = tmp_path / "tb3.yaml"
    profile.write_text("name: tb3\npose: {topic: /odom}\nimu: {topic: /imu}\n"
                       "lidar: {topic: /scan}\n")
    out = tmp_path / "out"
    r = kartci("localize", bags / BAG, "--profile", profile, "--out", out)
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "localization.json").read_text(encoding="utf-8"))
    # 457 scans (5 Hz) over 91 s; every odometry pose (30 Hz) has an estimate within 20 ms
    assert doc["scans"] == 457 and doc["poses"] == 2741
    assert abs(doc["log_s"] - 91.33) < 0.01
    assert doc["ape_rmse_m"] < 0.2 and doc["ape_max_m"] < 0.3  # measured 0.114 / 0.153
    assert (out / "map.ply").is_file() and doc["map_points"] > 1000


def test_a_missing_stream_is_named(bags: Path, tmp_path: Path) -> None:
    profile = tmp_path / "tb3.yaml"
    profile.write_text("name: tb3\npose: {topic: /odom}\nlidar: {topic: /scan}\n")
    r = kartci("localize", bags / BAG, "--profile", profile, "--out", tmp_path / "out")
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        f"kartci: error: {bags / BAG}: localization reads the lidar, the IMU and the odometry; "
        "profile tb3 names no imu (sensor_msgs/Imu) topic"]
