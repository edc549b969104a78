"""kartci's obstacle detector over a recorded robot's scans (`kartci localize --detect`),
checked against the world the log was recorded in.

The TurtleBot3 bag (fuse_tutorials' turtlebot3.bag) was driven in ROBOTIS' `turtlebot3_world`:
nine cylinders, radius 0.15 m, at x, y in {-1.1, 0, 1.1} m, inside a hexagonal wall. Source
of the positions: ROBOTIS-GIT/turtlebot3_simulations, turtlebot3_gazebo/models/
turtlebot3_world/model.sdf (commit 970a3d026d3e86a89c2fba254934e62edaecbcbb, Apache-2.0),
collisions `one_one` ... `three_three`. The bag's /odom is Gazebo's world pose, not the spawn
pose's frame: the burger's gazebo_ros_diff_drive plugin (ROBOTIS-GIT/turtlebot3,
turtlebot3_description/urdf/turtlebot3_burger.gazebo.xacro) sets no `odometrySource`, whose
default is `world` (the odometry has roll, pitch and z, which integrated wheels would not), so
the spawn pose (-2.0, -0.5) of turtlebot3_world.launch does not enter: every scan placed at its
odometry pose puts the pillars' returns on the SDF's circles (checked by plotting). The lidar
mount, -0.032 m back and 0.181 m up (turtlebot3_burger.urdf.xacro: base_joint 0.010 m,
scan_joint (-0.032, 0, 0.171) m), is given in the profile: the bag has no /tf_static.

Tolerance 0.2 m on a pillar's centre: the returns lie on the near side of the cylinder only,
so a box around them is centred between r/2 = 0.075 m (half the circumference seen) and
r = 0.15 m (a few beams on its face) from the axis, toward the robot; plus 0.05 m for the
lidar's noise (sigma 0.01 m, the xacro's) and half the 1-degree beam spacing at 3.5 m (0.03 m).
The pose has no drift to add (it is Gazebo's ground truth). Measured: 0.082 to 0.156 m.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from helpers import kartci

from kartci.pointcloud import read_ply, write_ply

BAG = "turtlebot3_gazebo_cmd_odom_scan.bag"
PILLARS = [(x, y) for x in (-1.1, 0.0, 1.1) for y in (-1.1, 0.0, 1.1)]  # m, the SDF's
PILLAR_TOL_M = 0.2  # see the module docstring
WALL_R_M = 2.2  # the hexagon's inner face is >= 2.28 m from the centre (its scan points)
WALL_STRETCH_M = 2.0  # a box this long is a stretch of wall (the sides are ~2.5 m)


def _nearest_pillar_m(o: dict[str, float]) -> float:
    return min(math.hypot(o["x_m"] - x, o["y_m"] - y) for x, y in PILLARS)


@pytest.mark.long(reason="end-to-end runs of real or synthetic logs")
def test_the_detector_finds_the_pillars_of_turtlebot3_world(bags: Path, tmp_path: Path) -> None:
    """Every pillar is a static track seen in >= 100 of the 457 scans within 0.2 m of its SDF
    position (measured: 197 to 390 scans, 0.082 to 0.156 m); nothing is detected in the free
    space: every other track is at the wall (centre >= 2.2 m out; measured >= 2.37 m) or a
    stretch of it longer than 2 m whose box's centre falls inside where the wall bends (2 such,
    both dynamic: with no map to mask them, a wall whose seen part grows as the robot drives
    has a moving centre). Measured: 31 static tracks (15 at the 9 pillars: a pillar hidden
    behind others for longer than keep_static_s, 3 s, is a new track when it reappears; with
    keep_static_s 1000 s there are 9, one per pillar, checked by hand), 14 dynamic. With
    the walls given as the map to mask, the 15 pillar tracks are all that is left; at the
    localization's estimate (APE max 0.16 m) they are within 0.22 m (0.2 m + its error)."""
    profile = tmp_path / "tb3.yaml"
    profile.write_text("name: tb3\npose: {topic: /odom}\nimu: {topic: /imu}\n"
                       "lidar: {topic: /scan, mount: {x_m: -0.032, z_m: 0.181}}\n")
    out = tmp_path / "out"
    r = kartci("localize", bags / BAG, "--profile", profile, "--out", out, "--detect")
    assert r.returncode == 0, r.stderr
    doc = json.loads((out / "detections.json").read_text(encoding="utf-8"))
    assert (doc["frame"], doc["poses"], doc["scans"]) == ("odom", "reference", 457)
    assert doc["mount"] == {"x_m": -0.032, "y_m": 0.0, "z_m": 0.181, "yaw_rad": 0.0,
                            "source": "profile"}
    static, dynamic = doc["static"], doc["dynamic"]
    for x, y in PILLARS:
        near = [o for o in static if math.hypot(o["x_m"] - x, o["y_m"] - y) < PILLAR_TOL_M]
        assert max((o["scans"] for o in near), default=0) >= 100, (x, y)
    assert all(_nearest_pillar_m(o) > 0.4 for o in dynamic)
    for o in static + dynamic:
        if _nearest_pillar_m(o) >= PILLAR_TOL_M:
            at_wall = math.hypot(o["x_m"], o["y_m"]) >= WALL_R_M
            assert at_wall or (o in dynamic and o["length_m"] > WALL_STRETCH_M), o
    assert (out / "detections.mcap").is_file()

    # the walls as the map (the log's own map beyond 2 m): every detection is a pillar
    cloud = read_ply(out / "map.ply")
    write_ply(tmp_path / "walls.ply", cloud[np.hypot(cloud[:, 0], cloud[:, 1]) > 2.0], "walls")
    r = kartci("localize", bags / BAG, "--profile", profile, "--out", tmp_path / "masked",
               "--detect", "--detect-map", tmp_path / "walls.ply")
    assert r.returncode == 0, r.stderr
    masked = json.loads((tmp_path / "masked" / "detections.json").read_text(encoding="utf-8"))
    assert masked["dynamic"] == []
    pillars = [(o["x_m"], o["y_m"], o["scans"]) for o in static
               if _nearest_pillar_m(o) < PILLAR_TOL_M]
    assert [(o["x_m"], o["y_m"], o["scans"]) for o in masked["static"]] == pillars
    assert len(pillars) == 15

    # at the localization's estimate instead: the same pillars, off by at most its error more
    r = kartci("localize", bags / BAG, "--profile", profile, "--out", tmp_path / "estimate",
               "--detect", "--detect-at", "estimate", "--detect-map", tmp_path / "walls.ply")
    assert r.returncode == 0, r.stderr
    est = json.loads((tmp_path / "estimate" / "detections.json").read_text(encoding="utf-8"))
    ape_max_m = json.loads((tmp_path / "estimate" / "localization.json").read_text(
        encoding="utf-8"))["ape_max_m"]
    assert est["poses"] == "estimate" and est["dynamic"] == []
    assert all(_nearest_pillar_m(o) < PILLAR_TOL_M + ape_max_m for o in est["static"])
    assert {min(PILLARS, key=lambda p: math.hypot(o["x_m"] - p[0], o["y_m"] - p[1]))
            for o in est["static"]} == set(PILLARS)


def test_detect_without_a_lidar_is_one_line(bags: Path, tmp_path: Path) -> None:
    profile = tmp_path / "tb3.yaml"
    profile.write_text("name: tb3\npose: {topic: /odom}\nimu: {topic: /imu}\n")
    r = kartci("localize", bags / BAG, "--profile", profile, "--out", tmp_path / "out",
               "--detect")
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [
        f"kartci: error: {bags / BAG}: localization reads the lidar and the odometry (and an "
        "IMU when there is one); profile tb3 names no lidar (LaserScan or PointCloud2) topic"]


def _with_tf_static(bag: Path, dst: Path, yaw: float) -> None:
    """`bag`'s /odom, /imu and /scan in a ROS 1 bag whose lidar is turned `yaw` rad left on
    its mount (each scan's angles start `yaw` earlier, so its returns are the same points in
    the base's frame), with the mount on /tf_static: base_footprint -> base_link (0.010 m up)
    -> base_scan (-0.032 m, 0.171 m up, yaw)."""
    from rosbags.highlevel import AnyReader
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)  # has no tf2_msgs: its one message, as in ROS 1
    store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                      "tf2_msgs/msg/TFMessage"))
    types = store.types

    def edge(parent: str, child: str, x: float, z: float, turn: float) -> Any:
        return types["geometry_msgs/msg/TransformStamped"](
            header=types["std_msgs/msg/Header"](
                seq=0, stamp=types["builtin_interfaces/msg/Time"](sec=112, nanosec=0),
                frame_id=parent),
            child_frame_id=child,
            transform=types["geometry_msgs/msg/Transform"](
                translation=types["geometry_msgs/msg/Vector3"](x=x, y=0.0, z=z),
                rotation=types["geometry_msgs/msg/Quaternion"](
                    x=0.0, y=0.0, z=math.sin(turn / 2), w=math.cos(turn / 2))))

    with AnyReader([bag], default_typestore=store) as reader, Writer(dst) as writer:
        conns = {c.topic: c for c in reader.connections if c.topic in ("/odom", "/imu", "/scan")}
        out = {t: writer.add_connection(t, c.msgtype, typestore=store) for t, c in conns.items()}
        tf = writer.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=store,
                                   latching=1)
        static = types["tf2_msgs/msg/TFMessage"](transforms=[
            edge("base_footprint", "base_link", 0.0, 0.010, 0.0),
            edge("base_link", "base_scan", -0.032, 0.171, yaw)])
        writer.write(tf, reader.start_time, store.serialize_ros1(static, "tf2_msgs/msg/TFMessage"))
        for conn, t_ns, raw in reader.messages(connections=list(conns.values())):
            if conn.topic == "/scan":
                m: Any = reader.deserialize(raw, conn.msgtype)
                m.angle_min -= yaw
                raw = bytes(store.serialize_ros1(m, conn.msgtype))
            writer.write(out[conn.topic], t_ns, raw)


@pytest.mark.long(reason="end-to-end runs of real or synthetic logs")
def test_the_mount_comes_from_tf_static_before_the_profile(bags: Path, tmp_path: Path) -> None:
    """The same scans from a lidar turned 90 degrees on its mount, the mount on /tf_static (a
    two-edge chain from the odometry's child frame): the same obstacles as with the unturned
    scans and the mount in the profile; the profile's (wrong) mount is not used. Without
    either, the mount is assumed at the base and the output says so."""
    yaw = math.pi / 2
    _with_tf_static(bags / BAG, tmp_path / "tf.bag", yaw)
    docs: list[dict[str, Any]] = []
    for log, mount in ((bags / BAG, ", mount: {x_m: -0.032, z_m: 0.181}"),
                       (tmp_path / "tf.bag", ", mount: {x_m: 5.0}"), (bags / BAG, "")):
        profile = tmp_path / "tb3.yaml"
        profile.write_text("name: tb3\npose: {topic: /odom}\nimu: {topic: /imu}\n"
                           f"lidar: {{topic: /scan{mount}}}\n")
        out = tmp_path / f"out{len(docs)}"
        r = kartci("localize", log, "--profile", profile, "--out", out, "--detect")
        assert r.returncode == 0, r.stderr
        docs.append(json.loads((out / "detections.json").read_text(encoding="utf-8")))
    given, tf, assumed = docs
    assert tf["mount"] == pytest.approx({"x_m": -0.032, "y_m": 0.0, "z_m": 0.181,
                                         "yaw_rad": yaw, "source": "tf_static"})
    for kind in ("static", "dynamic"):
        assert [o["id"] for o in tf[kind]] == [o["id"] for o in given[kind]]
        for a, b in zip(tf[kind], given[kind], strict=True):
            assert a == pytest.approx(b, abs=1e-3)
    assert assumed["mount"] == {"x_m": 0.0, "y_m": 0.0, "z_m": 0.0, "yaw_rad": 0.0,
                                "source": "assumed at the base (no /tf_static chain, no "
                                "profile mount)"}


def test_a_post_seen_from_a_turned_lidar_lands_where_it_stands(tmp_path: Path) -> None:
    """A post (a ring of returns, radius 0.15 m) at (2, 1) m seen in 12 scans from a robot
    driving by, its lidar 0.1 m forward, 0.3 m up and turned 90 degrees: one static obstacle at
    (2, 1) to float32's rounding, seen in every scan, its centre never moving (spread 0)."""
    from kartci.realdata.lidardetect import DetectAt, LidarMount, MountSource, detect_obstacles

    mount = LidarMount(0.1, 0.0, 0.3, math.pi / 2, MountSource.PROFILE)
    ring = np.array([(2 + 0.15 * math.cos(a), 1 + 0.15 * math.sin(a))
                     for a in np.linspace(0, math.tau, 36, endpoint=False)])
    poses = {k * 100_000_000: (0.1 * k, 0.05 * k, 0.02 * k) for k in range(12)}  # 10 Hz
    scans = []
    for t_ns, (x, y, yaw) in poses.items():
        c, s = math.cos(yaw), math.sin(yaw)  # world -> base, then base -> the turned lidar
        bx = c * (ring[:, 0] - x) + s * (ring[:, 1] - y) - mount.x_m
        by = -s * (ring[:, 0] - x) + c * (ring[:, 1] - y)
        scans.append((t_ns, np.column_stack([by, -bx, np.zeros(len(ring))])))
    found = detect_obstacles(scans, (DetectAt.REFERENCE, poses.__getitem__), True, mount,
                             "odom", "robot", None, tmp_path / "d.mcap")
    assert found.dynamic == () and len(found.static) == 1
    post = found.static[0]
    assert (post.x_m, post.y_m) == pytest.approx((2.0, 1.0), abs=1e-5)
    assert post.scans == 12 and post.height_m == pytest.approx(0.3)
    assert post.spread_m == pytest.approx(0.0, abs=1e-5)
