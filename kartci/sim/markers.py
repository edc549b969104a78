"""visualization_msgs/Marker(Array) for what Foxglove and RViz should draw from a run log: the
track's edges, centreline and lap line, obstacles and collisions. Drawing only: no metric reads
these topics."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from kartci.logs import msg
from kartci.logs.types import WORLD_FRAME

TRACK_MARKERS_TOPIC = "/kartci/track_markers"  # edges, centreline, lap line; latched, t = 0
COLLISION_MARKERS = "collision_markers"  # per robot: a sphere and a label at each collision

CUBE, SPHERE, LINE_STRIP, LINE_LIST, TEXT = 1, 2, 4, 5, 9  # visualization_msgs/Marker types
Rgba = tuple[float, float, float, float]


def _time(t_ns: int) -> Any:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    return msg("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec)


def _point(x: float, y: float, z: float = 0.0) -> Any:
    return msg("geometry_msgs/msg/Point", x=float(x), y=float(y), z=float(z))


def marker(ns: str, mid: int, kind: int, *, t_ns: int = 0, xyz: Sequence[float] = (0, 0, 0),
           yaw_rad: float = 0.0, scale: Sequence[float] = (1, 1, 1),
           rgba: Rgba = (1, 1, 1, 1), points: Sequence[Sequence[float]] = (),
           text: str = "") -> Any:
    """One ADD marker in the world frame, kept until replaced (lifetime 0)."""
    q = msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=math.sin(yaw_rad / 2),
            w=math.cos(yaw_rad / 2))
    header = msg("std_msgs/msg/Header", stamp=_time(t_ns), frame_id=WORLD_FRAME)
    return msg(
        "visualization_msgs/msg/Marker", header=header, ns=ns, id=mid, type=kind, action=0,
        pose=msg("geometry_msgs/msg/Pose", position=_point(*xyz), orientation=q),
        scale=msg("geometry_msgs/msg/Vector3", x=float(scale[0]), y=float(scale[1]),
                  z=float(scale[2])),
        color=msg("std_msgs/msg/ColorRGBA", r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]),
        lifetime=msg("builtin_interfaces/msg/Duration", sec=0, nanosec=0),
        frame_locked=False, points=[_point(*p) for p in points], colors=[],
        texture_resource="",
        texture=msg("sensor_msgs/msg/CompressedImage",
                    header=msg("std_msgs/msg/Header", stamp=_time(0), frame_id=""),
                    format="", data=np.zeros(0, np.uint8)),
        uv_coordinates=[], text=text, mesh_resource="",
        mesh_file=msg("visualization_msgs/msg/MeshFile", filename="",
                      data=np.zeros(0, np.uint8)),
        mesh_use_embedded_materials=False)


def array(markers: list[Any]) -> Any:
    """A visualization_msgs/MarkerArray."""
    return msg("visualization_msgs/msg/MarkerArray", markers=markers)


def _closed(xy: np.ndarray) -> list[tuple[float, float, float]]:
    return [(float(x), float(y), 0.01) for x, y in [*xy, xy[0]]]


def track_markers(centre: np.ndarray, left: np.ndarray, right: np.ndarray) -> Any:
    """Track edges (white), centreline (grey) and the lap line across the track at its start
    (red), as LINE_STRIP / LINE_LIST markers."""
    start = [(float(right[0, 0]), float(right[0, 1]), 0.02),
             (float(left[0, 0]), float(left[0, 1]), 0.02)]
    return array([
        marker("track_edges", 0, LINE_STRIP, scale=(0.08, 0, 0), points=_closed(left)),
        marker("track_edges", 1, LINE_STRIP, scale=(0.08, 0, 0), points=_closed(right)),
        marker("centreline", 0, LINE_STRIP, scale=(0.03, 0, 0), rgba=(0.6, 0.6, 0.6, 1),
               points=_closed(centre)),
        marker("lap_line", 0, LINE_LIST, scale=(0.15, 0, 0), rgba=(0.9, 0.1, 0.1, 1),
               points=start),
    ])


def collision_marker(n: int, t_ns: int, other: str, xyz: Sequence[float]) -> Any:
    """A red sphere where a collision began and a label naming what was hit."""
    return array([
        marker("collisions", 2 * n, SPHERE, t_ns=t_ns, xyz=xyz, scale=(0.4, 0.4, 0.4),
               rgba=(1, 0, 0, 0.8)),
        marker("collisions", 2 * n + 1, TEXT, t_ns=t_ns,
               xyz=(xyz[0], xyz[1], float(xyz[2]) + 0.6), scale=(0, 0, 0.3),
               text=f"collision: {other}"),
    ])
