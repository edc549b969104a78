"""Open-loop obstacle detection on a foreign log: kartci's obstacle detector (the registered
`obstacle_detector` node) fed every recorded lidar scan with the log's own pose at the scan's
stamp, on no map unless one is given (so every obstacle is reported, walls included). The
lidar's mount comes from the log's /tf_static (the pose's child frame -> the scan's frame),
else from the profile, else it is assumed at the base and the output says so. The result is
every static track the detector confirmed over the log, with the scans that saw it and the
spread of its per-scan box centre (one obstacle seen from many poses should land at one
place); its Detection3DArray and markers, with the scans placed in the pose's frame, go to a
small MCAP that Foxglove draws."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass
from enum import StrEnum
from pathlib import Path
from typing import Any

import numpy as np

from kartci.core import NODES, ROBOTS, AgentContext
from kartci.errors import LogError, SpecError
from kartci.logs import McapLogWriter, header, messages, msg, topics
from kartci.logs.types import WORLD_FRAME, yaw_from
from kartci.realdata.profile import Profile
from kartci.realdata.tfchain import TF_TYPES, TfTree

PoseAt = Callable[[int], tuple[float, float, float]]  # stamp ns -> x m, y m, yaw rad


class DetectAt(StrEnum):
    """Which poses the scans are placed at: the log's own, or the localization's estimate."""

    REFERENCE = "reference"
    ESTIMATE = "estimate"


class MountSource(StrEnum):
    """Where the lidar's mount came from."""

    TF_STATIC = "tf_static"
    PROFILE = "profile"
    ASSUMED = "assumed at the base (no /tf_static chain, no profile mount)"


@dataclass(frozen=True)
class LidarMount:
    """The lidar's frame in the base's: offsets (m) and yaw (rad)."""

    x_m: float
    y_m: float
    z_m: float
    yaw_rad: float
    source: MountSource


@dataclass(frozen=True)
class Obstacle:
    """One static track: its filtered centre (m, the pose's frame), its last box (m, rad),
    the scans that saw it, and the RMS distance of its per-scan box centres from their mean
    (m)."""

    id: int
    x_m: float
    y_m: float
    length_m: float
    width_m: float
    height_m: float
    yaw_rad: float
    scans: int
    spread_m: float


@dataclass(frozen=True)
class Detections:
    """What the detector found over the whole log."""

    frame: str  # the pose's frame, the obstacles' centres are in it
    at: DetectAt
    mount: LidarMount
    scans: int
    static: tuple[Obstacle, ...]
    dynamic: tuple[Obstacle, ...]  # tracks the detector called dynamic at some time

    def as_json(self) -> dict[str, Any]:
        """The document written to OUT/detections.json."""
        return {"frame": self.frame, "poses": self.at.value, "mount": asdict(self.mount),
                "scans": self.scans,
                **{kind: [{k: round(v, 4) if isinstance(v, float) else v
                           for k, v in asdict(o).items()} for o in tracks]
                   for kind, tracks in (("static", self.static), ("dynamic", self.dynamic))}}


def cloud_msg(t_ns: int, xyz: np.ndarray, frame: str = "velodyne_link") -> Any:
    """A PointCloud2 (x, y, z float32) of these points, as the nodes read a lidar."""
    fields = [msg("sensor_msgs/msg/PointField", name=n, offset=4 * i, datatype=7, count=1)
              for i, n in enumerate("xyz")]
    data = np.ascontiguousarray(xyz, dtype="<f4").tobytes()
    return msg("sensor_msgs/msg/PointCloud2", header=header(t_ns, frame), height=1,
               width=len(xyz), fields=fields, is_bigendian=False, point_step=12,
               row_step=12 * len(xyz), data=np.frombuffer(data, np.uint8), is_dense=True)


def _first(log: Path, topic: str) -> Any:
    found = next((m for _, _, m in messages(log, [topic])), None)
    if found is None:
        raise LogError(f"{log}: no message of {topic} could be read")
    return found


def frames(log: Path, profile: Profile) -> tuple[str, str, str]:
    """The pose's frame, its child (the base) and the lidar's frame, from their first
    messages (a TF pose names its frames in the profile)."""
    if profile.lidar is None:
        raise SpecError(f"profile {profile.name} names no lidar topic to detect obstacles in")
    sensor = str(_first(log, profile.lidar.topic).header.frame_id).lstrip("/")
    if profile.pose.is_tf:
        return str(profile.pose.parent), str(profile.pose.child), sensor
    pose = _first(log, profile.pose.topic)
    parent = str(getattr(getattr(pose, "header", None), "frame_id", "")) or WORLD_FRAME
    return parent.lstrip("/"), str(getattr(pose, "child_frame_id", "")).lstrip("/"), sensor


def lidar_mount(log: Path, profile: Profile, base: str, sensor: str) -> LidarMount:
    """base -> sensor from the log's /tf_static, else the profile's mount, else the base."""
    static = [i.topic for i in topics(log)
              if i.topic.endswith("tf_static") and i.msgtype in TF_TYPES and i.count]
    if static and base:
        tree = TfTree()
        for _, _, m in messages(log, static):
            tree.add(m, static=True)
        try:
            _, xyz, quat = tree.lookup(base, sensor, np.zeros(1, np.int64))
        except LogError:
            xyz = np.zeros((0, 3))
        if len(xyz):
            return LidarMount(float(xyz[0, 0]), float(xyz[0, 1]), float(xyz[0, 2]),
                              yaw_from(*(float(v) for v in quat[0])), MountSource.TF_STATIC)
    given = profile.lidar.mount if profile.lidar is not None else None
    if given is not None:
        return LidarMount(**given.model_dump(), source=MountSource.PROFILE)
    return LidarMount(0.0, 0.0, 0.0, 0.0, MountSource.ASSUMED)


def _node(ns: str, planar: bool, map_name: str | None) -> Any:
    """The registered obstacle detector, on `map_name` (none: no map); a planar scan has no
    ground to remove, so nothing is cut below it."""
    node = NODES.get("obstacle_detector")
    kinds = node.kinds()
    if not kinds:
        raise SpecError("no registered robot kind has the lidar the obstacle detector reads")
    model = ROBOTS.get(kinds[0]).params.model_validate({"kind": kinds[0]})
    params = node.params.model_validate({"map": map_name, **({"ground_m": -1.0} if planar
                                                             else {})})
    return node.build(params, AgentContext(ns, model, ()))


def _feed_mount(agent: Any, ns: str, mount: LidarMount) -> None:
    """The mount's offset as the node reads it (/tf_static); its yaw turns the points."""
    zero = msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=0.0, w=1.0)
    tf = msg("geometry_msgs/msg/TransformStamped", header=header(0, "base_link"),
             child_frame_id=f"{ns}/velodyne_link",
             transform=msg("geometry_msgs/msg/Transform", translation=msg(
                 "geometry_msgs/msg/Vector3", x=mount.x_m, y=mount.y_m, z=mount.z_m),
                 rotation=zero))
    agent.on_message("/tf_static", msg("tf2_msgs/msg/TFMessage", transforms=[tf]))


def _odometry(t_ns: int, frame: str, x: float, y: float, yaw: float) -> Any:
    """The pose as the node reads it, without twist: the node would deskew with it for a
    10 Hz spinning lidar, which a recorded scan (Gazebo's: one instant) need not be."""
    zero3 = msg("geometry_msgs/msg/Vector3", x=0.0, y=0.0, z=0.0)
    pose = msg("geometry_msgs/msg/Pose",
               position=msg("geometry_msgs/msg/Point", x=x, y=y, z=0.0),
               orientation=msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0,
                               z=math.sin(yaw / 2), w=math.cos(yaw / 2)))
    return msg("nav_msgs/msg/Odometry", header=header(t_ns, frame), child_frame_id="base_link",
               pose=msg("geometry_msgs/msg/PoseWithCovariance", pose=pose,
                        covariance=np.zeros(36)),
               twist=msg("geometry_msgs/msg/TwistWithCovariance", twist=msg(
                   "geometry_msgs/msg/Twist", linear=zero3, angular=zero3),
                   covariance=np.zeros(36)))


def _placed(xyz: np.ndarray, mount: LidarMount, pose: tuple[float, float, float]
            ) -> tuple[np.ndarray, np.ndarray]:
    """The scan turned by the mount's yaw (what the node is fed) and placed in the pose's
    frame (what the MCAP shows under it)."""
    c, s = math.cos(mount.yaw_rad), math.sin(mount.yaw_rad)
    turned = np.column_stack([c * xyz[:, 0] - s * xyz[:, 1], s * xyz[:, 0] + c * xyz[:, 1],
                              xyz[:, 2]])
    x, y, yaw = pose
    b = turned + np.array([mount.x_m, mount.y_m, mount.z_m])
    c, s = math.cos(yaw), math.sin(yaw)
    return turned, np.column_stack([x + c * b[:, 0] - s * b[:, 1], y + s * b[:, 0] + c * b[:, 1],
                                    b[:, 2]])


@dataclass
class _Seen:
    """Per track id: its box centre in each scan that updated it, and its last confirmed
    state."""

    centres: dict[int, list[tuple[float, float]]]
    last: dict[int, Any]

    def note(self, tracks: list[Any], t_s: float, confirm_hits: int) -> None:
        for tr in tracks:
            if tr.t_s == t_s:
                self.centres.setdefault(tr.id, []).append((tr.box.x, tr.box.y))
            if tr.hits >= confirm_hits:
                self.last[tr.id] = (tr.xy.copy(), tr.box, tr.hits, tr.moved)

    def obstacles(self, moving: bool) -> tuple[Obstacle, ...]:
        out = []
        for tid, (xy, box, hits, moved) in sorted(self.last.items()):
            if moved != moving:
                continue
            c = np.asarray(self.centres[tid])
            spread = float(np.sqrt(np.mean(np.sum((c - c.mean(axis=0)) ** 2, axis=1))))
            out.append(Obstacle(tid, float(xy[0]), float(xy[1]), box.length, box.width,
                                box.height, box.yaw, hits, spread))
        return tuple(out)


def detect_obstacles(scans: list[tuple[int, np.ndarray]], poses: tuple[DetectAt, PoseAt],
                     planar: bool, mount: LidarMount, frame: str, ns: str,
                     map_name: str | None, dst: Path) -> Detections:
    """Every scan (stamp ns, points in the lidar's frame) through the detector at the pose of
    its stamp; the detector's messages and the placed scans written to `dst` (MCAP)."""
    at, pose_at = poses
    agent = _node(ns, planar, map_name)
    _feed_mount(agent, ns, mount)
    seen = _Seen({}, {})
    confirm = agent.spec.confirm_hits
    with McapLogWriter(dst) as out:
        for t_ns, xyz in scans:
            pose = pose_at(t_ns)
            turned, placed = _placed(xyz, mount, pose)
            agent.on_message(agent.spec.pose_topic, _odometry(t_ns, frame, *pose))
            agent.on_message("velodyne_points", cloud_msg(t_ns, turned))
            for topic, m in agent.step(t_ns):
                out.write(f"/{ns}/{topic}", m, t_ns)
            out.write(f"/{ns}/obstacle_detector/scan", cloud_msg(t_ns, placed, WORLD_FRAME),
                      t_ns)
            seen.note(agent.tracker.tracks, t_ns * 1e-9, confirm)
    return Detections(frame, at, mount, len(scans), seen.obstacles(False),
                      seen.obstacles(True))
