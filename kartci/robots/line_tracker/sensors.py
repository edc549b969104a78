"""Line-sensor cameras (rendered by PyBullet, or computed from the floor geometry) and the sonar."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from kartci._bullet import pb
from kartci.robots.line_tracker.params import LineSensorSpec, SonarSpec
from kartci.robots.line_tracker.render import RenderScene
from kartci.sim.world import SENSED_GROUPS
from kartci.worlds.line_lab import LineLabWorld
from kartci.worlds.line_lab.world import LineLab

# Eq. 5.1 of the line-tracker source document (ITU-R BT.709 luma weights).
LUMA = np.array([0.2126, 0.7152, 0.0722])
NEAR_M, FAR_M = 0.001, 0.05
# Pixels the geometric mode samples per image side. Each sample's ink is anti-aliased (exact for
# an edge parallel to the grid), so 16 x 16 gives the same characterisation slope as 24 x 24 and
# 64 x 64 to 1e-9, at half the cost of 24 x 24.
GEOMETRIC_GRID_PX = 16
# Slack around a rendered camera's floor footprint when choosing the line's arcs to draw, m
FOOTPRINT_MARGIN_M = 0.005


class LineCamera:
    """One downward camera whose output is the mean luminance of its image (0 black, 1 white).

    `geometric` samples the floor seen through each pixel and measures the ink under it exactly;
    `rendered` asks PyBullet's TinyRenderer for the image. Both see the same light level.
    Given the `lab` it renders in, a rendered camera draws the lab's `RenderScene`: the same
    pixels for a fraction of the triangles.
    """

    def __init__(self, client: int, spec: LineSensorSpec, world: LineLabWorld,
                 lab: LineLab | None = None) -> None:
        self.client, self.spec, self.world, self.lab = client, spec, world, lab
        n = GEOMETRIC_GRID_PX
        u = (np.arange(n) + 0.5) / n * 2.0 - 1.0
        uu, vv = np.meshgrid(u, u)
        self._tan_half = math.tan(spec.fov_rad / 2)
        self._u, self._v = uu.ravel() * self._tan_half, vv.ravel() * self._tan_half
        t = self._tan_half  # the image's corner rays, as `_u` and `_v`
        self._corner_uv = [(a * t, b * t) for a in (-1.0, 1.0) for b in (-1.0, 1.0)]
        self._proj = pb.computeProjectionMatrixFOV(math.degrees(spec.fov_rad), 1.0, NEAR_M, FAR_M)

    def luminance(self, pos: NDArray[np.float64], rot: NDArray[np.float64]) -> float:
        """Mean image luminance for a camera at `pos` looking along its frame's x axis."""
        return self.luminances([(pos, rot)])[0]

    def luminances(self, poses: list[tuple[NDArray[np.float64], NDArray[np.float64]]]
                   ) -> list[float]:
        """Several cameras of the same kind at once (one numpy pass for the geometric mode)."""
        if self.spec.mode == "rendered":
            return [self._rendered(pos, rot) for pos, rot in poses]
        return self._geometric(poses)

    def _geometric(self, poses: list[tuple[NDArray[np.float64], NDArray[np.float64]]]
                   ) -> list[float]:
        pos = np.array([p for p, _ in poses])
        rot = np.array([r for _, r in poses])
        # one ray per pixel and camera, world frame, (camera, axis, pixel): u y + v z + x,
        # elementwise (not `@`: BLAS kernels differ by CPU), pixels innermost (fewer loops)
        rays = self._u * rot[:, :, 1, None]
        rays += self._v * rot[:, :, 2, None]
        rays += rot[:, :, 0, None]
        reach = pos[:, 2, None] / rays[:, 2]  # how far down each ray the floor is
        pixel = 0.0
        for z in pos[:, 2].tolist():
            pixel = max(pixel, 2.0 * z * self._tan_half / GEOMETRIC_GRID_PX)
        ink = self.world.course.ink_coverage(self.world.line_width_m,
                                             pos[:, 0, None] - reach * rays[:, 0],
                                             pos[:, 1, None] - reach * rays[:, 1], pixel)
        means = np.add.reduce(ink, axis=1) / ink.shape[1]  # ndarray.mean's sums, less wrapper
        return [self.world.light_level * (1.0 - m) for m in means.tolist()]

    def _footprint(self, pos: NDArray[np.float64], rot: NDArray[np.float64]
                   ) -> tuple[float, float, float, float] | None:
        """x-y box (x0, y0, x1, y1, m) around all the camera can see of the floor and anything on
        it: its four corner rays where they meet the floor, and the point below the camera (what
        sits above the floor is seen nearer to it); None when a corner ray misses the floor.
        Plain floats: a few dozen operations, cheaper than numpy calls."""
        (ax, bx, cx), (ay, by, cy), (az, bz, cz) = rot.tolist()
        px, py, pz = pos.tolist()
        if pz <= 0.0:
            return None
        xs, ys = [px], [py]
        for u, v in self._corner_uv:
            dx, dy, dz = ax + u * bx + v * cx, ay + u * by + v * cy, az + u * bz + v * cz
            if dz >= -1e-6:
                return None
            xs.append(px - pz / dz * dx)
            ys.append(py - pz / dz * dy)
        m = FOOTPRINT_MARGIN_M
        return min(xs) - m, min(ys) - m, max(xs) + m, max(ys) + m

    def _rendered(self, pos: NDArray[np.float64], rot: NDArray[np.float64]) -> float:
        n = self.spec.resolution_px
        if self.lab is not None:
            RenderScene.of(self.lab).show(self._footprint(pos, rot))
        view = pb.computeViewMatrix(pos.tolist(), (pos + 0.01 * rot[:, 0]).tolist(),
                                    rot[:, 2].tolist())
        img = pb.getCameraImage(n, n, view, self._proj, renderer=pb.ER_TINY_RENDERER,
                                lightAmbientCoeff=self.world.light_level, lightDiffuseCoeff=0.0,
                                lightSpecularCoeff=0.0, shadow=0,
                                flags=pb.ER_NO_SEGMENTATION_MASK, physicsClientId=self.client)
        rgb = np.asarray(img[2], dtype=np.float64).reshape(n, n, 4)[:, :, :3] / 255.0
        return float((rgb @ LUMA).mean())


class Sonar:
    """HC-SR04: nearest hit within a cone, quantised to its resolution; +inf when nothing."""

    def __init__(self, client: int, spec: SonarSpec) -> None:
        self.client, self.spec = client, spec
        half = math.atan2(spec.cone_radius_m, spec.max_range_m)
        dirs = [np.array([1.0, 0.0, 0.0])]
        ring = max(spec.rays - 1, 0)
        for k in range(ring):
            a = 2 * math.pi * k / ring
            dirs.append(np.array([math.cos(half), math.sin(half) * math.cos(a),
                                  math.sin(half) * math.sin(a)]))
        self._dirs = np.array(dirs)

    def range(self, pos: NDArray[np.float64], rot: NDArray[np.float64]) -> float:
        """Distance (m) to the nearest hit in the cone from a sensor's world position and rotation,
        quantised; +inf when nothing is in range."""
        s = self.spec
        world_dirs = self._dirs @ rot.T
        starts = pos + s.min_range_m * world_dirs
        ends = pos + s.max_range_m * world_dirs
        hits = pb.rayTestBatch(starts.tolist(), ends.tolist(), collisionFilterMask=SENSED_GROUPS,
                              physicsClientId=self.client)
        best = math.inf
        span = s.max_range_m - s.min_range_m
        for hit in hits:
            if hit[0] >= 0:
                best = min(best, s.min_range_m + hit[2] * span)
        if math.isinf(best):
            return best
        return round(best / s.resolution_m) * s.resolution_m
