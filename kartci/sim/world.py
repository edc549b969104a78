"""The PyBullet world every world kind builds on: DIRECT mode, fixed step, a floor, boxes."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from kartci._bullet import pb
from kartci.core import WorldParams
from kartci.scenario.models import Pose2D

if TYPE_CHECKING:
    from kartci.sim.robot import Robot

FLOOR_GROUP = 4  # collision-filter group of the floor; range sensors use SENSED_GROUPS
SENSED_GROUPS = 0xFFFF & ~FLOOR_GROUP


class World:
    """Owns one PyBullet physics client; every body lives in it. World kinds subclass it and
    build their bodies in `build()`, in a fixed order (PyBullet's results depend on it)."""

    # Bullet's cone friction (one coupled 2D row per contact) costs ~20 % of a kart's physics
    # step; a world whose robots' wheels carry no friction can use the cheaper pyramid (two 1D
    # rows), which only changes sliding contacts of bodies (a kart against a wall).
    CONE_FRICTION = True

    def __init__(self, spec: WorldParams, dt_s: float) -> None:
        self.spec = spec
        self.client = pb.connect(pb.DIRECT)
        c = self.client
        pb.resetSimulation(physicsClientId=c)
        pb.setGravity(0, 0, -9.81, physicsClientId=c)
        pb.setTimeStep(dt_s, physicsClientId=c)
        pb.setPhysicsEngineParameter(deterministicOverlappingPairs=1,
                                     enableConeFriction=int(self.CONE_FRICTION),
                                     physicsClientId=c)
        self.names: dict[int, str] = {}  # body id -> name, for collision reports
        self.robots: list[Robot] = []
        try:
            self.floor = self.build()
        except BaseException:
            self.close()
            raise
        self.names[self.floor] = "floor"

    def build(self) -> int:
        """Create the world's bodies; returns the floor's body id."""
        raise NotImplementedError

    def start_pose(self, start: Pose2D) -> tuple[float, float, float]:
        """x, y (m) and yaw (rad) of a start given along the world's course or track."""
        raise NotImplementedError

    def static_messages(self) -> list[tuple[str, Any]]:
        """Messages at t = 0 that describe the world; none by default."""
        return []

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
        """Advance the physics by one fixed step."""
        pb.stepSimulation(physicsClientId=self.client)

    def close(self) -> None:
        """Disconnect the physics client; closing twice is harmless."""
        if pb.isConnected(self.client):
            pb.disconnect(self.client)
