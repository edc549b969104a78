"""The line lab (seed 001, Sec. 5.2.1): a white floor with one black line, and obstacles."""

from __future__ import annotations

from typing import Any

import numpy as np

from kartci import geometry
from kartci._bullet import pb
from kartci.logs import header, msg
from kartci.scenario.models import LineLabWorld, Pose2D, StraightCourse
from kartci.sim.messages import WORLD_FRAME, pose
from kartci.sim.world import World

LINE_Z_M = 0.0002  # the line's visual sits 0.2 mm above the floor so the renderer sees it on top
COURSE_TOPIC = "/kartci/course"  # nav_msgs/Path: the line's axis or the track's centreline


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
        pts = geometry.polyline(spec.course)
        lo, hi = pts.min(axis=0) - 1.0, pts.max(axis=0) + 1.0
        floor = self._floor(lo, hi, spec.floor_friction)
        self.floor_box = (floor, (float(lo[0]), float(lo[1])), (float(hi[0]), float(hi[1])))
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
        self.ring = (pb.createMultiBody(0, -1, vis, physicsClientId=c), verts, idx)


def path_message(pts: Any) -> Any:
    """A polyline as nav_msgs/Path in the world frame."""
    poses = [msg("geometry_msgs/msg/PoseStamped", header=header(0, WORLD_FRAME),
                 pose=pose((float(x), float(y), 0.0), (0.0, 0.0, 0.0, 1.0))) for x, y in pts]
    return msg("nav_msgs/msg/Path", header=header(0, WORLD_FRAME), poses=poses)
