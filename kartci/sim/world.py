"""The PyBullet world: DIRECT mode, fixed step, a white floor with a black line, obstacles."""

from __future__ import annotations

import numpy as np

from kartci import geometry
from kartci._bullet import pb
from kartci.sim.hall import blocks
from kartci.spec.models import HallWorld, LineLabWorld, StraightCourse

FLOOR_GROUP = 4  # collision-filter group of the floor; range sensors use SENSED_GROUPS
SENSED_GROUPS = 0xFFFF & ~FLOOR_GROUP
LINE_Z_M = 0.0002  # the line's visual sits 0.2 mm above the floor so the renderer sees it on top


class World:
    """Owns one PyBullet physics client; every body lives in it."""

    def __init__(self, spec: LineLabWorld | HallWorld, dt_s: float) -> None:
        self.spec = spec
        self.client = pb.connect(pb.DIRECT)
        c = self.client
        pb.resetSimulation(physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setTimeStep(dt_s, physicsClientId=c)
        pb.setPhysicsEngineParameter(deterministicOverlappingPairs=1, physicsClientId=c)
        self.names: dict[int, str] = {}  # body id -> name, for collision reports
        if isinstance(spec, LineLabWorld):
            pts = geometry.polyline(spec.course)
            self.floor = self._floor(pts.min(axis=0) - 1.0, pts.max(axis=0) + 1.0,
                                     spec.floor_friction)
            self._line(spec)
            for i, b in enumerate(spec.obstacles):
                self.names[self._box(b.center_m, b.size_m, b.yaw_rad)] = f"obstacle_{i}"
        else:
            self.floor = self._floor(np.zeros(2), np.asarray(spec.size_m), 1.0)
            for blk in blocks(spec):
                self.names[self._box(blk.center, blk.size, blk.yaw)] = blk.name
            sx, sy = spec.size_m
            ceiling = self._box((sx / 2, sy / 2), (sx, sy, 0.1), 0.0)
            pb.resetBasePositionAndOrientation(ceiling, [sx / 2, sy / 2,
                                                         spec.wall_height_m + 0.05],
                                               [0, 0, 0, 1], physicsClientId=c)
            self.names[ceiling] = "ceiling"
        self.names[self.floor] = "floor"

    def _floor(self, lo: np.ndarray, hi: np.ndarray, friction: float) -> int:
        c = self.client
        centre, half = (lo + hi) / 2, (hi - lo) / 2
        col = pb.createCollisionShape(pb.GEOM_PLANE, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=[half[0], half[1], 0.001],
                                   rgbaColor=[1, 1, 1, 1],
                                   visualFramePosition=[centre[0], centre[1], -0.001],
                                   physicsClientId=c)
        body = pb.createMultiBody(0, col, vis, physicsClientId=c)
        pb.changeDynamics(body, -1, lateralFriction=friction, physicsClientId=c)
        # The floor is in its own collision group so range sensors can ignore it (a flat floor
        # at grazing incidence returns no ultrasonic echo); bodies still stand on it.
        pb.setCollisionFilterGroupMask(body, -1, FLOOR_GROUP, 0xFFFF, physicsClientId=c)
        return int(body)

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
        pb.createMultiBody(0, -1, vis, physicsClientId=c)

    def _box(self, centre: tuple[float, float], size: tuple[float, float, float],
             yaw: float) -> int:
        c = self.client
        half = [s / 2 for s in size]
        col = pb.createCollisionShape(pb.GEOM_BOX, halfExtents=half, physicsClientId=c)
        vis = pb.createVisualShape(pb.GEOM_BOX, halfExtents=half, rgbaColor=[0.8, 0.3, 0.1, 1],
                                   physicsClientId=c)
        orn = pb.getQuaternionFromEuler([0, 0, yaw])
        return int(pb.createMultiBody(0, col, vis, [centre[0], centre[1], half[2]], orn,
                                      physicsClientId=c))

    def step(self) -> None:
        pb.stepSimulation(physicsClientId=self.client)

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)
