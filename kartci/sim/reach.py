"""Whether a body can touch anything but the floor: a sphere around its centre of mass that
holds all its links, against the boxes of the world's static bodies. PyBullet's
`getContactPoints` lists every contact of a body, the floor's included (a kart's wheels give
about fifteen a step, 15 µs of a 200 µs step), so a robot asks it only when the sphere meets a
box, or whenever a body that moves (another robot) is in the world; its answer is then the same
as asking every step."""

from __future__ import annotations

import itertools
import math

from kartci._bullet import pb
from kartci.sim.body import Reading

# Beyond the links' boxes (which hold Bullet's collision margin already): Bullet keeps contact
# points up to its breaking threshold (2 cm) apart, and steering swings the front wheels, m.
MARGIN_M = 0.5


class Reach:
    """The bounding sphere of `body` and the boxes of the world's other bodies."""

    def __init__(self, client: int, body: int, floor: int, dt_s: float) -> None:
        """Measure the body's sphere from its links' boxes as loaded (dt_s: the physics step,
        s: contacts are found before the step moves the body)."""
        self.client, self.body, self.floor, self.dt = client, body, floor, dt_s
        com = pb.getBasePositionAndOrientation(body, physicsClientId=client)[0]
        reach = 0.0
        for link in range(-1, pb.getNumJoints(body, physicsClientId=client)):
            lo, hi = pb.getAABB(body, link, physicsClientId=client)
            for corner in itertools.product(*zip(lo, hi, strict=True)):
                reach = max(reach, math.dist(corner, com))
        self.radius_m = reach + MARGIN_M
        self._bodies = -1  # bodies in the world when the boxes were taken
        self._boxes: tuple[tuple[float, float, float, float, float, float], ...] = ()
        self._moving = False  # a body that moves is in the world: always ask

    def _survey(self) -> None:
        """The boxes of every other static body; a moving one (mass or joints) sets
        `_moving`. Taken again when the number of bodies changes."""
        c = self.client
        self._bodies = pb.getNumBodies(physicsClientId=c)
        boxes, self._moving = [], False
        for i in range(self._bodies):
            b = pb.getBodyUniqueId(i, physicsClientId=c)
            if b in (self.body, self.floor):
                continue
            if (pb.getNumJoints(b, physicsClientId=c)
                    or pb.getDynamicsInfo(b, -1, physicsClientId=c)[0] > 0):
                self._moving = True
                return
            lo, hi = pb.getAABB(b, -1, physicsClientId=c)
            boxes.append((*lo, *hi))
        self._boxes = tuple(boxes)

    def clear(self, rd: Reading) -> bool:
        """True when nothing but the floor can touch the body read as `rd` (just after a
        physics step, whose contacts were found where the body was before it)."""
        if pb.getNumBodies(physicsClientId=self.client) != self._bodies:
            self._survey()
        if self._moving:
            return False
        x, y, z = rd.com
        v = rd.lin
        e = self.radius_m + 2.0 * (abs(v[0]) + abs(v[1]) + abs(v[2])) * self.dt
        for x0, y0, z0, x1, y1, z1 in self._boxes:
            if x0 - e < x < x1 + e and y0 - e < y < y1 + e and z0 - e < z < z1 + e:
                return False
        return True
