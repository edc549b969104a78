"""Hall geometry as boxes: walls, pillars and obstacles, shared by PyBullet and the fast lidar."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kartci._bullet import pb
from kartci.logs import msg
from kartci.sim.line_lab import COURSE_TOPIC, path_message
from kartci.sim.messages import WORLD_FRAME, pose
from kartci.sim.world import World
from kartci.spec.models import HallWorld, Pose2D, WorldParams
from kartci.track import OBSTACLES_TOPIC, TRACK_TOPIC, load_track


@dataclass(frozen=True)
class Block:
    """A vertical box standing on the floor: centre (m), size (m), yaw (rad)."""

    name: str
    center: tuple[float, float]
    size: tuple[float, float, float]
    yaw: float = 0.0


def blocks(spec: HallWorld) -> list[Block]:
    sx, sy = spec.size_m
    t, h = spec.wall_thickness_m, spec.wall_height_m
    out = [
        Block("wall_south", (sx / 2, -t / 2), (sx + 2 * t, t, h)),
        Block("wall_north", (sx / 2, sy + t / 2), (sx + 2 * t, t, h)),
        Block("wall_west", (-t / 2, sy / 2), (t, sy, h)),
        Block("wall_east", (sx + t / 2, sy / 2), (t, sy, h)),
    ]
    p = spec.pillar_size_m
    out += [Block(f"pillar_{i}", (x, y), (p, p, h)) for i, (x, y) in enumerate(spec.pillars_m)]
    out += [Block(f"obstacle_{i}", b.center_m, b.size_m, b.yaw_rad)
            for i, b in enumerate(spec.obstacles)]
    return out


class Hall(World):
    """An indoor hall: floor, walls, pillars, obstacles, a ceiling, and a closed track."""

    spec: HallWorld

    def __init__(self, spec: WorldParams, dt_s: float) -> None:
        assert isinstance(spec, HallWorld)
        self.track_file = Path(spec.track)
        self.track = load_track(self.track_file)
        self.blocks = blocks(spec)
        super().__init__(spec, dt_s)

    def build(self) -> int:
        spec = self.spec
        floor = self._floor(np.zeros(2), np.asarray(spec.size_m), 1.0)
        for blk in self.blocks:
            self.names[self._box(blk.center, blk.size, blk.yaw)] = blk.name
        sx, sy = spec.size_m
        ceiling = self._box((sx / 2, sy / 2), (sx, sy, 0.1), 0.0)
        pb.resetBasePositionAndOrientation(ceiling, [sx / 2, sy / 2, spec.wall_height_m + 0.05],
                                           [0, 0, 0, 1], physicsClientId=self.client)
        self.names[ceiling] = "ceiling"
        return floor

    def start_pose(self, start: Pose2D) -> tuple[float, float, float]:
        x, y, yaw = self.track.pose_at(start.along_m, start.lateral_m)
        return x, y, yaw + start.heading_rad

    def static_messages(self) -> list[tuple[str, Any]]:
        """The course, the track itself (the log is self-contained) and the obstacles."""
        xy = self.track.xy[:: max(1, len(self.track.xy) // 400)]
        return [(COURSE_TOPIC, path_message(xy)),
                (TRACK_TOPIC, msg("std_msgs/msg/String",
                                  data=self.track_file.read_text(encoding="utf-8"))),
                (OBSTACLES_TOPIC, obstacle_markers(self.spec))]

    def friction_at(self, x: float, y: float) -> float:
        """Floor friction under a point: the zone it is in, else the hall's floor."""
        f = self.spec.floor_friction
        for z in self.spec.zones:
            if z.min_m[0] <= x <= z.max_m[0] and z.min_m[1] <= y <= z.max_m[1]:
                f = z.friction
        return f


def obstacle_markers(spec: HallWorld) -> Any:
    """The static obstacles as CUBE markers (ground truth; Foxglove draws them too)."""
    import math

    markers = []
    for i, b in enumerate(spec.obstacles):
        q = (0.0, 0.0, math.sin(b.yaw_rad / 2), math.cos(b.yaw_rad / 2))
        markers.append(msg(
            "visualization_msgs/msg/Marker",
            header=msg("std_msgs/msg/Header",
                       stamp=msg("builtin_interfaces/msg/Time", sec=0, nanosec=0),
                       frame_id=WORLD_FRAME),
            ns="obstacles", id=i, type=1, action=0,
            pose=pose((b.center_m[0], b.center_m[1], b.size_m[2] / 2), q),
            scale=msg("geometry_msgs/msg/Vector3", x=b.size_m[0], y=b.size_m[1],
                      z=b.size_m[2]),
            color=msg("std_msgs/msg/ColorRGBA", r=0.8, g=0.3, b=0.1, a=1.0),
            lifetime=msg("builtin_interfaces/msg/Duration", sec=0, nanosec=0),
            frame_locked=False, points=[], colors=[], texture_resource="",
            texture=msg("sensor_msgs/msg/CompressedImage", header=msg(
                "std_msgs/msg/Header", stamp=msg("builtin_interfaces/msg/Time", sec=0,
                                                 nanosec=0), frame_id=""),
                format="", data=np.zeros(0, np.uint8)),
            uv_coordinates=[], text="", mesh_resource="",
            mesh_file=msg("visualization_msgs/msg/MeshFile", filename="",
                          data=np.zeros(0, np.uint8)),
            mesh_use_embedded_materials=False))
    return msg("visualization_msgs/msg/MarkerArray", markers=markers)
