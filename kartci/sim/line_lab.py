"""The line lab (seed 001, Sec. 5.2.1): a white floor with one black line, and obstacles."""

from __future__ import annotations

from typing import Any

import numpy as np

from kartci import geometry
from kartci._bullet import pb
from kartci.logs import header, msg
from kartci.sim.messages import WORLD_FRAME, pose
from kartci.sim.world import World
from kartci.spec.models import LineLabWorld, Pose2D, StraightCourse

LINE_Z_M = 0.0002  # the line's visual sits 0.2 mm above the floor so the renderer sees it on top
COURSE_TOPIC = "/kartci/course"  # nav_msgs/Path: the line's axis or the track's centreline


class LineLab(World):
    """A floor with the line (a straight strip or a ring) and obstacles."""

    spec: LineLabWorld
    _ring: tuple[int, list[list[float]], list[int]] | None = None  # body, vertices, indices
    _arcs: LineArcs | None = None

    def build(self) -> int:
        """Floor around the course with a 1 m margin, the line (visual only, no collision) and
        obstacle boxes."""
        spec = self.spec
        pts = geometry.polyline(spec.course)
        floor = self._floor(pts.min(axis=0) - 1.0, pts.max(axis=0) + 1.0, spec.floor_friction)
        self._line(spec)
        for i, b in enumerate(spec.obstacles):
            self.names[self._box(b.center_m, b.size_m, b.yaw_rad)] = f"obstacle_{i}"
        return floor

    def start_pose(self, start: Pose2D) -> tuple[float, float, float]:
        """Pose of the point that starts on the course (the line tracker's sensor point)."""
        x, y, yaw = geometry.pose_at(self.spec.course, start.along_m, start.lateral_m)
        return x, y, yaw + start.heading_rad

    def static_messages(self) -> list[tuple[str, Any]]:
        """The course as a path, for controllers and metrics."""
        return [(COURSE_TOPIC, path_message(geometry.polyline(self.spec.course, 200)))]

    def end_m(self) -> float | None:
        """Length of a straight course (robots are done past it); None for a closed course."""
        course = self.spec.course
        return geometry.length_m(course) if isinstance(course, StraightCourse) else None

    def _line(self, spec: LineLabWorld) -> None:
        c, course, w = self.client, spec.course, spec.line_width_m
        if isinstance(course, StraightCourse):
            x0, y0, yaw = geometry.start_pose(course)
            length = geometry.length_m(course)
            vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[length / 2, w / 2, LINE_Z_M / 2],
                                       rgbaColor=[0, 0, 0, 1], physicsClientId=c)
            mid = [x0 + np.cos(yaw) * length / 2, y0 + np.sin(yaw) * length / 2, LINE_Z_M / 2]
            orn = pb.getQuaternionFromEuler([0, 0, yaw])
            pb.createMultiBody(0, -1, vis, mid, orn, physicsClientId=c)
            return
        n = 360  # chords of 1 degree: 19 um sagitta at r = 0.5 m, well below a pixel
        a = np.linspace(0, 2 * np.pi, n, endpoint=False)
        verts: list[list[float]] = []
        for r in (course.radius_m - w / 2, course.radius_m + w / 2):
            verts += np.column_stack([course.center_m[0] + r * np.cos(a),
                                      course.center_m[1] + r * np.sin(a),
                                      np.full(n, LINE_Z_M)]).tolist()
        idx: list[int] = []
        for i in range(n):
            j = (i + 1) % n
            idx += [i, n + i, n + j, i, n + j, j]  # counter-clockwise seen from above
        vis = pb.createVisualShape(pb.GEOM_MESH, vertices=verts, indices=idx,
                                   rgbaColor=[0, 0, 0, 1], physicsClientId=c)
        self._ring = (pb.createMultiBody(0, -1, vis, physicsClientId=c), verts, idx)

    def line_arcs(self) -> LineArcs | None:
        """The ring split into arcs the renderer can skip (None for a straight line, whose box
        is cheap): made on first use, after every other body, so only rendered runs pay for them
        and no body id moves."""
        if self._arcs is None and self._ring is not None:
            self._arcs = LineArcs(self.client, *self._ring)
        return self._arcs



class LineArcs:
    """The ring's triangles as `ARCS` visual-only bodies of consecutive chords, the same
    vertices, in the same order. PyBullet's TinyRenderer transforms every triangle of every
    visible shape per image and skips shapes with alpha 0; a line camera's footprint covers one
    or two arcs, so hiding the whole ring and showing only the arcs near the footprint gives the
    same pixels (every other triangle projects outside the image) for ~1/20 of the triangles."""

    ARCS = 36  # 10 degrees each: 6 cm of line at r = 0.36 m, 2.5x a camera's footprint

    def __init__(self, client: int, ring: int, verts: list[list[float]], idx: list[int]) -> None:
        self.client = client
        pb.changeVisualShape(ring, -1, rgbaColor=[0, 0, 0, 0], physicsClientId=client)
        tris = len(idx) // 3
        per = -(-tris // self.ARCS)
        self.bodies: list[int] = []
        lo, hi = [], []
        for start in range(0, tris, per):
            part = idx[3 * start:3 * min(start + per, tris)]
            used = sorted(set(part))
            local = {v: i for i, v in enumerate(used)}
            pts = [verts[v] for v in used]
            vis = pb.createVisualShape(pb.GEOM_MESH, vertices=pts,
                                       indices=[local[v] for v in part],
                                       rgbaColor=[0, 0, 0, 1], physicsClientId=client)
            # maximal coordinates: a static object costs the physics step less than a multibody
            self.bodies.append(pb.createMultiBody(0, -1, vis, useMaximalCoordinates=True,
                                                  physicsClientId=client))
            xy = np.asarray(pts)[:, :2]
            lo.append(xy.min(axis=0))
            hi.append(xy.max(axis=0))
        (self.x0, self.y0), (self.x1, self.y1) = np.array(lo).T, np.array(hi).T
        self.shown = np.ones(len(self.bodies), dtype=bool)

    def show(self, box: tuple[float, float, float, float] | None) -> None:
        """Show only the arcs whose bounding box meets `box` (x0, y0, x1, y1, m); all for None."""
        if box is None:
            want = np.ones(len(self.bodies), dtype=bool)
        else:
            x0, y0, x1, y1 = box
            want = (self.x0 <= x1) & (self.y0 <= y1) & (self.x1 >= x0) & (self.y1 >= y0)
        changed = want != self.shown
        if not changed.any():
            return
        for i in np.flatnonzero(changed).tolist():
            pb.changeVisualShape(self.bodies[i], -1, rgbaColor=[0, 0, 0, float(want[i])],
                                 physicsClientId=self.client)
        self.shown = want

def path_message(pts: Any) -> Any:
    """A polyline as nav_msgs/Path in the world frame."""
    poses = [msg("geometry_msgs/msg/PoseStamped", header=header(0, WORLD_FRAME),
                 pose=pose((float(x), float(y), 0.0), (0.0, 0.0, 0.0, 1.0))) for x, y in pts]
    return msg("nav_msgs/msg/Path", header=header(0, WORLD_FRAME), poses=poses)
