"""The `obstacle_detector` node: each lidar scan, deskewed with the kart's twist and put into the
map frame with its pose, loses its floor, ceiling and every point near the map; what is left is
clustered, boxed and tracked. Publishes `obstacle_detector/detections`
(vision_msgs/Detection3DArray: the standard 3D detection type Foxglove and ROS tools draw; the
class is `static` or `dynamic`, the id the track's) and `obstacle_detector/markers`
(visualization_msgs/MarkerArray: static boxes blue, dynamic ones orange, as in the source document's
Fig. 6.4)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kartci.core import AgentContext, Outbox
from kartci.localization.deskew import deskew
from kartci.localization.node import map_path
from kartci.logs.types import WORLD_FRAME, header, msg, stamp_ns, yaw_of
from kartci.perception.clusters import MapMask, clusters, obstacle_points
from kartci.perception.params import DetectorParams
from kartci.perception.tracker import Track, Tracker
from kartci.pointcloud import cloud_xyz, read_ply

SCAN_RATE_HZ = 10.0
STATIC, DYNAMIC = "static", "dynamic"
COLOURS = {STATIC: (0.2, 0.4, 1.0), DYNAMIC: (1.0, 0.55, 0.0)}


class ObstacleDetector:
    """One kart's obstacle detector (see the module's docstring)."""

    def __init__(self, spec: DetectorParams, ctx: AgentContext) -> None:
        """Load the map's walls and fixed objects; tracks start empty."""
        self.spec, self.ns, self.period_s = spec, ctx.name, spec.period_s
        self.inputs: tuple[str, ...] = ("/tf_static", spec.pose_topic, "velodyne_points")
        cloud = read_ply(map_path(spec.map, ctx)) if spec.map is not None else np.zeros((0, 3))
        self.mask = MapMask(cloud, spec.ground_m, spec.top_m)
        self.tracker = Tracker(spec.gate_m, spec.dynamic_mps, spec.dynamic_m)
        self.mount = np.array([0.0, 0.0, spec.sensor_height_m])
        self.pose: tuple[float, float, float, float, float, float, float] | None = None
        self.scan: tuple[int, np.ndarray] | None = None

    def on_message(self, topic: str, message: Any) -> None:
        """Mount from /tf_static, the latest pose and twist, the scan for the next step."""
        if topic == "/tf_static":
            for tf in message.transforms:
                if tf.child_frame_id == f"{self.ns}/velodyne_link":
                    t = tf.transform.translation
                    self.mount = np.array([t.x, t.y, t.z])
        elif topic == self.spec.pose_topic:
            p, tw = message.pose.pose.position, message.twist.twist
            self.pose = (p.x, p.y, p.z, yaw_of(message.pose.pose.orientation),
                         float(tw.linear.x), float(tw.linear.y), float(tw.angular.z))
        elif topic == "velodyne_points":
            self.scan = (stamp_ns(message.header), cloud_xyz(message))

    def step(self, t_ns: int) -> Outbox:
        """Detect and track on a waiting scan; publish the confirmed tracks."""
        if self.scan is None or self.pose is None:
            return []
        stamp, xyz = self.scan
        self.scan = None
        x, y, z, yaw, v, vy, w = self.pose
        xyz = deskew(xyz[np.isfinite(xyz).all(axis=1)], v - w * self.mount[1], w, SCAN_RATE_HZ,
                     vy + w * self.mount[0]) + self.mount
        c, s = math.cos(yaw), math.sin(yaw)
        world = np.column_stack([x + c * xyz[:, 0] - s * xyz[:, 1],
                                 y + s * xyz[:, 0] + c * xyz[:, 1], z + xyz[:, 2]])
        sp = self.spec
        pts = obstacle_points(world, np.array([x, y]), self.mask, sp.ground_m, sp.top_m,
                              sp.map_clearance_m, sp.max_range_m)
        t_s = stamp * 1e-9
        self.tracker.update(t_s, clusters(pts, sp.cluster_gap_m, sp.min_points))
        self.tracker.prune(t_s, sp.keep_static_s, sp.keep_dynamic_s, sp.established_hits)
        shown = [tr for tr in self.tracker.tracks if tr.hits >= sp.confirm_hits]
        return [("obstacle_detector/detections", self._detections(stamp, shown)),
                ("obstacle_detector/markers", self._markers(stamp, shown))]

    def _detections(self, t_ns: int, tracks: list[Track]) -> Any:
        out = []
        for tr in tracks:
            kind = DYNAMIC if tr.moved else STATIC
            pose = _pose(float(tr.xy[0]), float(tr.xy[1]), tr.box.height / 2,
                         self.tracker.heading(tr))
            out.append(msg("vision_msgs/msg/Detection3D", header=header(t_ns, WORLD_FRAME),
                           results=[msg("vision_msgs/msg/ObjectHypothesisWithPose",
                                        hypothesis=msg("vision_msgs/msg/ObjectHypothesis",
                                                       class_id=kind, score=1.0),
                                        pose=msg("geometry_msgs/msg/PoseWithCovariance",
                                                 pose=pose, covariance=np.zeros(36)))],
                           bbox=msg("vision_msgs/msg/BoundingBox3D",
                                    center=_pose(float(tr.xy[0]), float(tr.xy[1]),
                                                 tr.box.height / 2, tr.box.yaw),
                                    size=_vec(max(tr.box.length, 0.05),
                                              max(tr.box.width, 0.05), tr.box.height)),
                           id=str(tr.id)))
        return msg("vision_msgs/msg/Detection3DArray", header=header(t_ns, WORLD_FRAME),
                   detections=out)

    def _markers(self, t_ns: int, tracks: list[Track]) -> Any:
        markers = [_marker(t_ns, 0, 3, _pose(0.0, 0.0, 0.0, 0.0), _vec(1, 1, 1), (0, 0, 0))]
        for tr in tracks:  # DELETEALL above, then this scan's boxes
            markers.append(_marker(
                t_ns, tr.id, 0,
                _pose(float(tr.xy[0]), float(tr.xy[1]), tr.box.height / 2, tr.box.yaw),
                _vec(max(tr.box.length, 0.05), max(tr.box.width, 0.05), tr.box.height),
                COLOURS[DYNAMIC if tr.moved else STATIC]))
        return msg("visualization_msgs/msg/MarkerArray", markers=markers)


def _marker(t_ns: int, marker_id: int, action: int, pose: Any, scale: Any,
            rgb: tuple[float, float, float]) -> Any:
    """A CUBE marker with every field of visualization_msgs/Marker set."""
    hdr = header(t_ns, WORLD_FRAME)
    return msg("visualization_msgs/msg/Marker", header=hdr, ns="obstacles", id=marker_id,
               type=1, action=action, pose=pose, scale=scale,
               color=msg("std_msgs/msg/ColorRGBA", r=rgb[0], g=rgb[1], b=rgb[2], a=0.6),
               lifetime=msg("builtin_interfaces/msg/Duration", sec=0, nanosec=0),
               frame_locked=False, points=[], colors=[], texture_resource="",
               texture=msg("sensor_msgs/msg/CompressedImage", header=hdr, format="",
                           data=np.zeros(0, np.uint8)),
               uv_coordinates=[], text="", mesh_resource="",
               mesh_file=msg("visualization_msgs/msg/MeshFile", filename="",
                             data=np.zeros(0, np.uint8)),
               mesh_use_embedded_materials=False)


def _vec(x: float, y: float, z: float) -> Any:
    return msg("geometry_msgs/msg/Vector3", x=float(x), y=float(y), z=float(z))


def _pose(x: float, y: float, z: float, yaw: float) -> Any:
    return msg("geometry_msgs/msg/Pose",
               position=msg("geometry_msgs/msg/Point", x=x, y=y, z=float(z)),
               orientation=msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0,
                               z=math.sin(yaw / 2), w=math.cos(yaw / 2)))
