"""One scan to obstacle boxes: ground, ceiling and map points removed, the rest clustered by
distance, each cluster boxed along its principal axis."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

Array = np.ndarray


@dataclass(frozen=True)
class Box:
    """An obstacle's box on the floor: centre (m, map frame), size along and across its
    heading (m), height (m), heading (rad)."""

    x: float
    y: float
    length: float
    width: float
    height: float
    yaw: float
    points: int


class MapMask:
    """The map's points between floor and `top`, in 2D, for "is this the hall?" queries."""

    def __init__(self, map_xyz: Array, ground_m: float, top_m: float) -> None:
        """Keep the map's walls, pillars and fixed objects (not its floor or ceiling)."""
        band = (map_xyz[:, 2] > ground_m) & (map_xyz[:, 2] < top_m)
        self.tree = cKDTree(map_xyz[band, :2]) if band.any() else None

    def near(self, xy: Array, clearance_m: float) -> Array:
        """True for points within `clearance_m` of the map."""
        if self.tree is None or len(xy) == 0:
            return np.zeros(len(xy), bool)
        d, _ = self.tree.query(xy, distance_upper_bound=clearance_m)
        return np.asarray(np.isfinite(d))


def obstacle_points(world_xyz: Array, origin_xy: Array, mask: MapMask, ground_m: float,
                    top_m: float, clearance_m: float, max_range_m: float) -> Array:
    """The points (N, 3, map frame) that are neither floor, ceiling, far, nor the map."""
    keep = (world_xyz[:, 2] > ground_m) & (world_xyz[:, 2] < top_m)
    d = world_xyz[:, :2] - origin_xy
    keep &= np.einsum("ij,ij->i", d, d) < max_range_m**2
    pts = world_xyz[keep]
    out: Array = pts[~mask.near(pts[:, :2], clearance_m)]
    return out


def clusters(pts: Array, gap_m: float, min_points: int) -> list[Box]:
    """Connected components of points closer than `gap_m` (x, y), boxed."""
    if len(pts) < min_points:
        return []
    pairs = cKDTree(pts[:, :2]).query_pairs(gap_m, output_type="ndarray")
    n = len(pts)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    count, labels = connected_components(graph, directed=False)
    out = []
    for k in range(count):
        member = pts[labels == k]
        if len(member) >= min_points:
            out.append(box(member))
    return out


def box(pts: Array) -> Box:
    """The box of a cluster: heading along the principal axis of its x, y, extents along and
    across it, from the floor to its highest point."""
    xy = pts[:, :2]
    c = xy.mean(axis=0)
    cov = np.cov((xy - c).T) if len(xy) > 1 else np.eye(2)
    w, v = np.linalg.eigh(cov)
    axis = v[:, int(np.argmax(w))]
    yaw = math.atan2(axis[1], axis[0])
    rot = np.array([[math.cos(yaw), math.sin(yaw)], [-math.sin(yaw), math.cos(yaw)]])
    local = (xy - c) @ rot.T
    lo, hi = local.min(axis=0), local.max(axis=0)
    mid = c + ((lo + hi) / 2) @ rot
    yaw = (yaw + math.pi / 2) % math.pi - math.pi / 2  # a box's heading is modulo pi
    return Box(float(mid[0]), float(mid[1]), float(hi[0] - lo[0]), float(hi[1] - lo[1]),
               float(pts[:, 2].max()), yaw, len(pts))
