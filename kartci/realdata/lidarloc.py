"""Open-loop replay of a real robot's log through kartci's localization node: the recorded
lidar (LaserScan as a planar cloud, or PointCloud2), IMU and odometry (its forward speed as the
wheel speeds of the node's odometry model) fed on log time, the estimate scored against the
log's own pose with evo's APE. Without a map, one is built from the log itself: every scan
placed at the recorded pose, voxel-thinned (so the score measures how well registration and
the filter follow the recorded motion, not the map's truth).

A log without an IMU (many diff-drive robots record scan + odometry + commands only) is
predicted from the odometry alone: each odometry message stands in for a gyro sample, its yaw
rate (the twist's, or the recorded yaw's rate of change when the twist holds none) and the
lateral acceleration of a robot that does not slip (v x yaw rate). The replay says so
(`Prediction.ODOMETRY`): the filter then cannot see a side slip the wheels did not."""

from __future__ import annotations

import math
import tempfile
import time
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from kartci.core import NODES, ROBOTS, AgentContext
from kartci.errors import SpecError
from kartci.logs import header, messages, msg
from kartci.metrics.trajectory import ErrorStats, Trajectory, ape, associate
from kartci.pointcloud import cloud_xyz, voxel_downsample, write_ply
from kartci.project import Project
from kartci.realdata.importer import import_log
from kartci.realdata.lidardetect import (
    DetectAt,
    Detections,
    PoseAt,
    cloud_msg,
    detect_obstacles,
    frames,
    lidar_mount,
)
from kartci.realdata.profile import Profile, resolve_profile
from kartci.worlds.track import TRACK_TOPIC

MAP_VOXEL_M = 0.05  # a small robot's scans: a few cm between points


class Prediction(StrEnum):
    """What the filter's prediction step reads between scans."""

    IMU = "imu"  # the log's IMU: gyro yaw rate and lateral acceleration
    ODOMETRY = "odometry"  # no IMU in the log: the odometry's yaw rate, no side slip


@dataclass(frozen=True)
class LocReplay:
    """What the replay gave: the estimate's APE against the log's pose, and its cost."""

    ape: ErrorStats  # m
    scans: int
    estimates: int
    log_s: float
    wall_s: float
    map_points: int
    prediction: Prediction
    detections: Detections | None = None  # with `detect`
    detect_s: float = 0.0  # wall time of the detection, s


def scan_points(m: Any) -> np.ndarray:
    """A LaserScan's valid returns as points (N, 3) in its frame (z 0), or a PointCloud2's."""
    if m.__msgtype__ == "sensor_msgs/msg/PointCloud2":
        return cloud_xyz(m)
    r = np.asarray(m.ranges, float)
    a = float(m.angle_min) + float(m.angle_increment) * np.arange(len(r))
    ok = np.isfinite(r) & (r >= float(m.range_min)) & (r <= float(m.range_max))
    return np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]), np.zeros(ok.sum())])


@dataclass(frozen=True)
class _Recorded:
    t_ns: np.ndarray
    pose: np.ndarray  # x, y, yaw (unwrapped) per odometry message
    speed: np.ndarray  # forward m/s
    yaw_rate: np.ndarray  # rad/s per odometry message: its twist's, else the yaw's rate
    imu: list[tuple[int, Any]]
    scans: list[tuple[int, np.ndarray]]

    def at(self, t_ns: int) -> tuple[float, float, float]:
        return tuple(float(np.interp(t_ns, self.t_ns, self.pose[:, k]))  # type: ignore[return-value]
                     for k in range(3))


def _read(imported: Path, ns: str) -> _Recorded:
    odom, imu, scans = [], [], []
    for topic, _, m in messages(imported, [f"/{ns}/odom", f"/{ns}/imu", f"/{ns}/scan",
                                           f"/{ns}/velodyne_points"]):
        stamp = int(m.header.stamp.sec) * 1_000_000_000 + int(m.header.stamp.nanosec)
        if topic.endswith("/odom"):
            p, q = m.pose.pose.position, m.pose.pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            odom.append((stamp, p.x, p.y, yaw, m.twist.twist.linear.x,
                         m.twist.twist.angular.z))
        elif topic.endswith("/imu"):
            imu.append((stamp, m))
        else:
            scans.append((stamp, scan_points(m)))
    rows = np.array(odom, float)
    rows[:, 3] = np.unwrap(rows[:, 3])
    t_ns = rows[:, 0].astype(np.int64)
    rate = rows[:, 5]
    if not rate.any() and len(rows) > 1:  # a pose-only odometry: the recorded yaw's rate
        rate = np.gradient(rows[:, 3], t_ns * 1e-9)
    return _Recorded(t_ns, rows[:, 1:4], rows[:, 4], rate, imu, scans)


def build_map(rec: _Recorded, path: Path) -> int:
    """Every scan at the recorded pose of its stamp, thinned; written as PLY. Points."""
    parts = []
    for t_ns, xyz in rec.scans:
        x, y, yaw = rec.at(t_ns)
        c, s = math.cos(yaw), math.sin(yaw)
        parts.append(np.column_stack([x + c * xyz[:, 0] - s * xyz[:, 1],
                                      y + s * xyz[:, 0] + c * xyz[:, 1], xyz[:, 2]]))
    cloud = voxel_downsample(np.vstack(parts), MAP_VOXEL_M)
    write_ply(path, cloud, "kartci: a map built from the log's own scans at its recorded poses")
    return len(cloud)


def _start_track(x: float, y: float, yaw: float) -> str:
    """A 5 m circle through the first recorded pose, tangent to its heading: the node's
    initial guess is the track's pose 0 m along."""
    r = 5.0
    cx, cy = x - r * math.sin(yaw), y + r * math.cos(yaw)
    a0 = math.atan2(y - cy, x - cx)
    rows = [f"{cx + r * math.cos(a0 + k * math.tau / 64):.6f},"
            f"{cy + r * math.sin(a0 + k * math.tau / 64):.6f},1.0,1.0" for k in range(64)]
    return "# x_m,y_m,w_tr_right_m,w_tr_left_m\n" + "\n".join(rows) + "\n"


def _node(map_ply: Path, ns: str, min_range_m: float) -> tuple[Any, Any]:
    """The localization node on the log's map, and the wheel odometry model its kind uses."""
    node = NODES.get("localization")
    kinds = node.kinds()
    if not kinds:
        raise SpecError("no registered robot kind has the wheel odometry localization reads")
    kind = ROBOTS.get(kinds[0])
    model = kind.params.model_validate({"kind": kinds[0]})
    params = node.params.model_validate({
        "map": str(map_ply), "deskew": False, "sensor_height_m": 0.0,
        "min_range_m": min_range_m, "scan_voxel_m": MAP_VOXEL_M, "map_voxel_m": MAP_VOXEL_M,
        "max_correspondence_m": 0.3, "registration_std_m": 0.02, "registration_std_rad": 0.01,
        "initial": {"error_xy_m": (0.0, 0.0), "error_yaw_rad": 0.0, "std_xy_m": 0.05,
                    "std_yaw_rad": 0.02}})
    assert kind.odometry is not None  # node.kinds() lists only kinds with odometry
    return node.build(params, AgentContext(ns, model, ())), kind.odometry(model)


def _check_streams(profile: Any, log: Path) -> None:
    if profile.lidar is None:
        raise SpecError(f"{log}: localization reads the lidar and the odometry (and an IMU "
                        f"when there is one); profile {profile.name} names no lidar (LaserScan "
                        "or PointCloud2) topic")


def replay_localization(log: Path, profile_path: Path | None, out: Path, proj: Project,
                        detect: DetectAt | None = None, detect_map: str | None = None
                        ) -> LocReplay:
    """Replay `log` through the localization node open loop (see the module docstring); the
    built map goes to OUT/map.ply. With `detect`, its scans also go through the obstacle
    detector at the log's poses or the estimate's (on `detect_map`, default none):
    OUT/detections.mcap."""
    t_wall = time.perf_counter()
    profile, info = resolve_profile(log, profile_path, proj, sensors=True)
    _check_streams(profile, log)
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        imported = Path(tmp) / "imported.mcap"
        import_log(log, profile, {r: i.msgtype for r, i in info.items()}, imported)
        rec = _read(imported, profile.agent)
    n_map = build_map(rec, out / "map.ply")
    agent, wheels = _node((out / "map.ply").resolve(), profile.agent, 0.12)  # not a world's
    agent.on_message(TRACK_TOPIC, msg("std_msgs/msg/String",
                                      data=_start_track(*rec.pose[0])))
    prediction = Prediction.IMU if rec.imu else Prediction.ODOMETRY
    est = _run(agent, rec, wheels)
    ref = Trajectory.planar(rec.t_ns * 1e-9, rec.pose[:, 0], rec.pose[:, 1], rec.pose[:, 2])
    r, e = associate(ref, est, max_diff_s=0.02)
    t_detect = time.perf_counter()
    found = None
    if detect is not None:
        poses = (detect, rec.at if detect == DetectAt.REFERENCE else _pose_at(est))
        found = _detect(log, profile, info["lidar"].msgtype, rec.scans, poses, out, detect_map)
    return LocReplay(ape(r, e), len(rec.scans), len(est), float(rec.t_ns[-1] - rec.t_ns[0])
                     * 1e-9, time.perf_counter() - t_wall, n_map, prediction, found,
                     time.perf_counter() - t_detect if detect is not None else 0.0)


def _pose_at(est: Trajectory) -> PoseAt:
    """The estimate's planar pose at a stamp (interpolated; held before its first)."""
    t = est.t_s
    x, y = est.xyz_m[:, 0], est.xyz_m[:, 1]
    yaw = np.unwrap(2 * np.arctan2(est.quat_xyzw[:, 2], est.quat_xyzw[:, 3]))
    return lambda t_ns: (float(np.interp(t_ns * 1e-9, t, x)),
                         float(np.interp(t_ns * 1e-9, t, y)),
                         float(np.interp(t_ns * 1e-9, t, yaw)))


def _detect(log: Path, profile: Profile, lidar_type: str, scans: list[tuple[int, np.ndarray]],
            poses: tuple[DetectAt, PoseAt], out: Path, detect_map: str | None) -> Detections:
    """The recorded scans through the obstacle detector at the chosen poses."""
    frame, base, sensor = frames(log, profile)
    return detect_obstacles(scans, poses, lidar_type == "sensor_msgs/msg/LaserScan",
                            lidar_mount(log, profile, base, sensor), frame, profile.agent,
                            detect_map, out / "detections.mcap")


def _run(agent: Any, rec: _Recorded, wheels: Any) -> Trajectory:
    """Feed the log in time order, stepping the node every period; its estimates. Without an
    IMU, each odometry message is also a gyro sample (see the module docstring)."""
    feed: list[tuple[int, int, str, Any]] = [(t, 0, "imu", m) for t, m in rec.imu]
    if not rec.imu:
        feed += [(int(t), 0, "imu", _odometry_gyro(int(t), float(v), float(w)))
                 for t, v, w in zip(rec.t_ns, rec.speed, rec.yaw_rate, strict=True)]
    feed += [(t, 1, "velodyne_points", xyz) for t, xyz in rec.scans]
    feed += [(int(t), 2, "joint_states", float(v)) for t, v in zip(rec.t_ns, rec.speed,
                                                                    strict=True)]
    feed.sort(key=lambda f: (f[0], f[1]))
    period = round(agent.period_s * 1e9)
    tick = feed[0][0] - feed[0][0] % period
    rows: list[tuple[float, float, float, float]] = []
    for t_ns, _, topic, value in feed:
        while tick < t_ns:
            rows += _estimates(agent.step(tick))
            tick += period
        agent.on_message(topic, _message(topic, value, t_ns, wheels))
    t, x, y, yaw = (np.array(c) for c in zip(*rows, strict=True))
    return Trajectory.planar(t, x, y, np.unwrap(yaw))


def _odometry_gyro(t_ns: int, v_mps: float, w_radps: float) -> Any:
    """An IMU sample made of odometry: its yaw rate, and the lateral acceleration of a robot
    that does not slip (v w), so that the filter's side velocity stays at zero."""
    unknown = np.zeros(9)  # covariances: none given (the node uses its own noise model)
    return msg("sensor_msgs/msg/Imu", header=header(t_ns, "base_link"),
               orientation=msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0),
               orientation_covariance=np.full(9, -1.0),  # REP 145: no orientation
               angular_velocity=msg("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=w_radps),
               angular_velocity_covariance=unknown,
               linear_acceleration=msg("geometry_msgs/msg/Vector3", x=0.0, y=v_mps * w_radps,
                                       z=0.0),
               linear_acceleration_covariance=unknown)


def _message(topic: str, value: Any, t_ns: int, wheels: Any) -> Any:
    if topic == "velodyne_points":
        return cloud_msg(t_ns, value)
    if topic == "joint_states":
        spin = value / wheels.radius_m
        return msg("sensor_msgs/msg/JointState", header=header(t_ns, "base_link"),
                   name=list(wheels.joints), position=np.zeros(len(wheels.joints)),
                   velocity=np.full(len(wheels.joints), spin), effort=np.zeros(0))
    return value


def _estimates(outbox: list[tuple[str, Any]]) -> list[tuple[float, float, float, float]]:
    out = []
    for topic, m in outbox:
        if topic == "localization/odom":
            p, q = m.pose.pose.position, m.pose.pose.orientation
            out.append((int(m.header.stamp.sec) + int(m.header.stamp.nanosec) * 1e-9, p.x, p.y,
                        math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))))
    return out
