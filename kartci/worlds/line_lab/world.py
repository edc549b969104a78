"""The line lab (seed 001, Sec. 5.2.1): a white floor with one black line, and obstacles."""

from __future__ import annotations

from typing import Any

import numpy as np

from kartci._bullet import pb
from kartci.scenario.models import Pose2D
from kartci.sim.world import World
from kartci.worlds.line_lab.course import CircleCourse, StraightCourse
from kartci.worlds.line_lab.params import LineLabWorld
from kartci.worlds.messages import COURSE_TOPIC, path_message

LINE_Z_M = 0.0002  # the line's visual sits 0.2 mm above the floor so the renderer sees it on top


class LineLab(World):
    """A floor with the line (a straight strip or a ring) and obstacles."""

    spec: LineLabWorld
    # what a rendered line camera redraws cheaply (the line tracker's `render`): the floor's
    # box (visual body id, x-y corners lo, hi), the ring's body, vertices and triangle indices
    # (None for a straight line), and the scene made from them on the first rendered frame
    floor_box: tuple[int, tuple[float, float], tuple[float, float]]
    ring: tuple[int, list[list[float]], list[int]] | None = None
    render_scene: Any = None

    def build(self) -> int:
        """Floor around the course with a 1 m margin, the line (visual only, no collision) and
        obstacle boxes."""
        spec = self.spec
        pts = spec.course.polyline()
        lo, hi = pts.min(axis=0) - 1.0, pts.max(axis=0) + 1.0
        floor = self._floor(lo, hi, spec.floor_friction)
        self.floor_box = (floor, (float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1])))
        self._line(spec)
        for i, b in enumerate(spec.obstacles):
            self.names[self._box(b.center_m, b.size_m, b.yaw_rad)] = f"obstacle_{i}"
        return floor

    def start_pose(self, start: Pose2D) -> tuple[float, float, float]:
        """Pose of the point that starts on the course (the line tracker's sensor point)."""
        x, y, yaw = self.spec.course.pose_at(start.along_m, start.lateral_m)
        return x, y, yaw + start.heading_rad

    def static_messages(self) -> list[tuple[str, Any]]:
        """The course as a path, for controllers and metrics."""
        return [(COURSE_TOPIC, path_message(self.spec.course.polyline(200)))]

    def end_m(self) -> float | None:
        """Length of a straight course (robots are done past it); None for a closed course."""
        course = self.spec.course
        return None if course.closed else course.length_m()

    def _line(self, spec: LineLabWorld) -> None:
        course = spec.course
        if isinstance(course, StraightCourse):  # the line lab's own shapes: a strip or a ring
            self._strip(course, spec.line_width_m)
        else:
            self._ring(course, spec.line_width_m)

    def _strip(self, course: StraightCourse, w: float) -> None:
        c = self.client
        x0, y0, yaw = course.start_pose()
        length = course.length_m()
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[length / 2, w / 2, LINE_Z_M / 2],
                                   rgbaColor=[0, 0, 0, 1], physicsClientId=c)
        mid = [x0 + np.cos(yaw) * length / 2, y0 + np.sin(yaw) * length / 2, LINE_Z_M / 2]
        orn = pb.getQuaternionFromEuler([0, 0, yaw])
        pb.createMultiBody(0, -1, vis, mid, orn, physicsClientId=c)

    def _ring(self, course: CircleCourse, w: float) -> None:
        c = self.client
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
        self.ring = (pb.createMultiBody(0, -1, vis, physicsClientId=c), verts, idx)

