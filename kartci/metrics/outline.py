"""Robots seen from above: an outline is a few convex polygons (its parts) in the robot's body
frame; placed at each pose of a path, the gap between two outlines is the clearance.

Outlines come from a robot's description (a URDF's collision shapes, recorded in the run log
as `/<agent>/robot_description`), so clearance is measured against the same geometry that
collides in the simulator. Pure numpy: no simulator, no polygon library (convex parts make
the distance two loops of point-to-segment distances and a separating-axis test).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from kartci.core import Outline, Polygon
from kartci.errors import SpecError

Array = NDArray[np.float64]
Placed = list[Array]  # per part of an outline: (poses, vertices, 2) corners in the world, m
CIRCLE_SIDES = 32  # a circle becomes this polygon drawn round it: 0.6 mm over at r 0.127 m
_ROWS = 256  # poses per block in `gap_m`: bounds the (poses, n, m) temporaries to a few MB


def hull(points: Array) -> Polygon:
    """Convex hull of 2D points, counter-clockwise (Andrew's monotone chain)."""
    pts = sorted({(float(x), float(y)) for x, y in points})
    if len(pts) < 3:
        return tuple(pts)

    def half(seq: list[tuple[float, float]]) -> list[tuple[float, float]]:
        out: list[tuple[float, float]] = []
        for p in seq:
            while len(out) >= 2 and ((out[-1][0] - out[-2][0]) * (p[1] - out[-2][1])
                                     - (out[-1][1] - out[-2][1]) * (p[0] - out[-2][0])) <= 0:
                out.pop()
            out.append(p)
        return out

    return tuple(half(pts)[:-1] + half(pts[::-1])[:-1])


def box(center_m: Sequence[float], length_m: float, width_m: float, yaw_rad: float) -> Polygon:
    """A `length_m` x `width_m` rectangle centred on `center_m`, turned by `yaw_rad`."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    half_l, half_w = length_m / 2, width_m / 2
    return tuple((center_m[0] + c * x - s * y, center_m[1] + s * x + c * y)
                 for x, y in ((half_l, half_w), (-half_l, half_w), (-half_l, -half_w),
                              (half_l, -half_w)))


def _ring(radius_m: float, z_m: float = 0.0) -> Array:
    """A circle's circumscribed polygon in its own plane (z = `z_m`): never inside the circle,
    and with edges, not corners, facing +-x and +-y, so its extent along them is the radius."""
    k = (np.arange(CIRCLE_SIDES) + 0.5) * (2 * math.pi / CIRCLE_SIDES)
    r = radius_m / math.cos(math.pi / CIRCLE_SIDES)
    return np.column_stack([r * np.cos(k), r * np.sin(k), np.full(CIRCLE_SIDES, z_m)])


def _shape_points(geometry: ET.Element, where: str) -> Array:
    """Points whose plan-view hull is one collision shape, in the shape's own frame."""
    shape = next(iter(geometry), None)
    tag = "" if shape is None else shape.tag
    try:
        if shape is not None and tag == "box":
            half = np.fromstring(shape.get("size", ""), sep=" ") / 2
            corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)])
            return np.asarray(corners * half, dtype=float)
        if shape is not None and tag == "sphere":
            return _ring(float(shape.get("radius", "")))
        if shape is not None and tag == "cylinder":
            r, half_len = float(shape.get("radius", "")), float(shape.get("length", "")) / 2
            return np.vstack([_ring(r, -half_len), _ring(r, half_len)])
    except ValueError as err:
        raise SpecError(f"{where}: a {tag} without its size ({err})") from err
    raise SpecError(f"{where}: a {tag or 'missing'} collision shape has no outline (boxes, "
                    "spheres and cylinders have)")


def _origin(el: ET.Element | None) -> tuple[Array, Array]:
    """An `<origin>`'s translation (m) and rotation matrix (URDF rpy: fixed x, then y, then z)."""
    origin = None if el is None else el.find("origin")
    xyz = np.fromstring(origin.get("xyz", "0 0 0"), sep=" ") if origin is not None else (
        np.zeros(3))
    rpy = np.fromstring(origin.get("rpy", "0 0 0"), sep=" ") if origin is not None else (
        np.zeros(3))
    if xyz.shape != (3,) or rpy.shape != (3,):
        raise SpecError("URDF: an origin needs three numbers in xyz and rpy")
    from scipy.spatial.transform import Rotation  # start-up: 0.3 s, for robots with a URDF

    return xyz, Rotation.from_euler("xyz", rpy).as_matrix()


def _link_poses(root: ET.Element) -> dict[str, tuple[Array, Array]]:
    """Every link's pose in the root link (the one no joint moves) at zero joint angles."""
    joints = {}
    for joint in root.iter("joint"):
        up, down = joint.find("parent"), joint.find("child")
        if up is not None and down is not None:
            joints[down.get("link", "")] = (up.get("link", ""), *_origin(joint))
    links = {link.get("name", "") for link in root.iter("link")}
    poses: dict[str, tuple[Array, Array]] = {n: (np.zeros(3), np.eye(3)) for n in links
                                             if n not in joints}
    while not links <= poses.keys():
        ready = [(child, j) for child, j in joints.items()
                 if child not in poses and j[0] in poses]
        if not ready:
            raise SpecError("URDF: a link is not connected to the root by joints")
        for child, (parent, xyz, rot) in ready:
            at, turn = poses[parent]
            poses[child] = (at + turn @ xyz, turn @ rot)
    return poses


def urdf_outline(text: str) -> Outline:
    """A URDF's collision shapes at zero joint angles seen from above, in its root link's frame,
    m: one convex part per shape, less the parts inside another."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as err:  # expat's message gives the place, not the text
        raise SpecError(f"robot description: cannot read URDF ({err})") from err
    poses = _link_poses(root)
    parts = []
    for link in root.iter("link"):
        name = link.get("name", "")
        at, turn = poses[name]
        for col in link.findall("collision"):
            geometry = col.find("geometry")
            if geometry is None:
                continue
            xyz, rot = _origin(col)
            pts = _shape_points(geometry, f"URDF link {name}") @ (turn @ rot).T + at + turn @ xyz
            parts.append(hull(pts[:, :2]))
    if not parts:
        raise SpecError("robot description: the URDF has no collision shapes, so no outline")
    return tuple(p for i, p in enumerate(parts)
                 if not any(j != i and inside(p, q) for j, q in enumerate(parts)))


def inside(part: Polygon, other: Polygon) -> bool:
    """Whether every corner of `part` lies in the convex polygon `other` (on its edge counts);
    an identical part is not inside (both are kept)."""
    if len(other) < 3 or part == other:
        return False
    q = np.asarray(other)
    d = np.roll(q, -1, axis=0) - q
    for x, y in part:
        if np.any(d[:, 0] * (y - q[:, 1]) - d[:, 1] * (x - q[:, 0]) < -1e-12):
            return False
    return True


def bounds(outline: Outline) -> tuple[float, float, float, float]:
    """The outline's bounding box: centre x and y, length (along x) and width (along y), m."""
    pts = np.asarray([p for part in outline for p in part])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = hi - lo
    return float(lo[0] + size[0] / 2), float(lo[1] + size[1] / 2), float(size[0]), float(size[1])


def placed(outline: Outline, poses: Array) -> Placed:
    """Each part's corners at every pose (x, y, yaw; m, rad), in the world frame."""
    c, s = np.cos(poses[:, 2])[:, None], np.sin(poses[:, 2])[:, None]
    out = []
    for part in outline:
        px, py = np.asarray(part)[:, 0][None, :], np.asarray(part)[:, 1][None, :]
        out.append(np.stack([poses[:, 0:1] + c * px - s * py,
                             poses[:, 1:2] + s * px + c * py], axis=-1))
    return out


def _separated(a: Array, b: Array) -> NDArray[np.bool_]:
    """Per pose, whether an edge normal of either convex polygon separates them (SAT)."""
    out = np.zeros(len(a), dtype=bool)
    for poly in (a, b):
        edge = np.roll(poly, -1, axis=1) - poly
        nx, ny = -edge[:, :, 1:2], edge[:, :, 0:1]  # (poses, edges, 1)
        pa = nx * a[:, None, :, 0] + ny * a[:, None, :, 1]
        pb = nx * b[:, None, :, 0] + ny * b[:, None, :, 1]
        out |= ((pa.max(axis=2) < pb.min(axis=2)) | (pb.max(axis=2) < pa.min(axis=2))).any(
            axis=1)
    return out


def _corner_to_edge_m(p: Array, q: Array) -> Array:
    """Per pose, the least distance from a corner of `p` to an edge of `q`, m."""
    a = q[:, None, :, :]
    ab = np.roll(q, -1, axis=1)[:, None, :, :] - a
    ap = p[:, :, None, :] - a
    t = np.clip((ap[..., 0] * ab[..., 0] + ap[..., 1] * ab[..., 1])
                / (ab[..., 0] ** 2 + ab[..., 1] ** 2), 0.0, 1.0)
    out: Array = np.hypot(ap[..., 0] - t * ab[..., 0], ap[..., 1] - t * ab[..., 1]).min(
        axis=(1, 2))
    return out


def gap_m(a: Array, b: Array) -> Array:
    """Per pose, the distance between two convex polygons given as (poses, corners, 2) arrays,
    m; 0 where they touch or overlap."""
    out = np.empty(len(a))
    for i in range(0, len(a), _ROWS):
        pa, pb = a[i:i + _ROWS], b[i:i + _ROWS]
        dist = np.minimum(_corner_to_edge_m(pa, pb), _corner_to_edge_m(pb, pa))
        out[i:i + _ROWS] = np.where(_separated(pa, pb), dist, 0.0)
    return out


def outline_gap_m(a: Placed, b: Placed) -> Array:
    """Per pose, the distance between two placed outlines (their nearest parts), m."""
    n = min(len(a[0]), len(b[0]))
    out: Array = np.minimum.reduce([gap_m(pa[:n], pb[:n]) for pa in a for pb in b])
    return out


def fixed(part: Polygon, poses: int) -> Array:
    """A part that does not move (an obstacle), repeated for `poses` poses."""
    return np.broadcast_to(np.asarray(part, dtype=float), (poses, len(part), 2))
