"""Velodyne scans, fast: one 2D cast per azimuth against the 2.5D hall, each ring solved
analytically (floor, ceiling, the side or the top of every block). PyBullet's batched ray test is
kept as the exact reference (`scan_reference`), and a test holds the two together.

The fast model uses the sensor's position and yaw only: a kart on a flat floor pitches and
rolls well under a degree.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from kartci._bullet import pb
from kartci.sim.blocks import Block

Array = NDArray[np.float64]


@dataclass(frozen=True)
class LidarModel:
    """Table 3.5 of the go-kart source document."""

    name: str
    elevations_rad: Array  # one per ring, lowest first
    resolution_per_hz_deg: float  # horizontal resolution = this * rotation rate
    range_accuracy_m: float

    def azimuths(self, rate_hz: float) -> Array:
        """Beam azimuths of one revolution (rad, from 0) at the model's resolution for `rate_hz`."""
        n = round(360.0 / (self.resolution_per_hz_deg * rate_hz))
        return np.arange(n, dtype=float) * (2 * np.pi / n)


MODELS = {
    # 16 channels, +-15 deg every 2 deg; 0.1 deg at 5 Hz .. 0.4 deg at 20 Hz; +-3 cm
    "vlp16": LidarModel("VLP-16", np.radians(np.arange(-15.0, 15.01, 2.0)).astype(float), 0.02,
                        0.03),
    # 32 channels, -30.67 .. +10.67 deg every 1.333 deg; 0.08 deg at 5 Hz .. 0.33 at 20 Hz; +-2 cm
    "hdl32e": LidarModel("HDL-32E", np.radians(np.linspace(-30.67, 10.67, 32)).astype(float),
                         0.0165, 0.02),
}


def _box_intervals(origin: Array, cos_t: Array, sin_t: Array,
                   blocks: list[Block]) -> tuple[Array, Array]:
    """Horizontal entry / exit distance of each azimuth ray (direction cos_t, sin_t) through
    each block (B, A), the rays starting at `origin` (2,) or each at its own (A, 2). Slabs per
    axis as 1D arrays: reducing (A, 2) arrays over their short axis was the cost."""
    t_in = np.full((len(blocks), len(cos_t)), np.inf)
    t_out = np.full_like(t_in, np.inf)
    for i, b in enumerate(blocks):
        c, s = math.cos(b.yaw), math.sin(b.yaw)
        ox, oy = origin[..., 0] - b.center[0], origin[..., 1] - b.center[1]
        ox, oy = c * ox + s * oy, -s * ox + c * oy
        dx, dy = c * cos_t + s * sin_t, -s * cos_t + c * sin_t
        hx, hy = b.size[0] / 2, b.size[1] / 2
        with np.errstate(divide="ignore", invalid="ignore"):
            x1, x2 = (-hx - ox) / dx, (hx - ox) / dx
            y1, y2 = (-hy - oy) / dy, (hy - oy) / dy
        lo = np.fmax(np.minimum(x1, x2), np.minimum(y1, y2))  # fmax/fmin: a NaN slab is open
        hi = np.fmin(np.maximum(x1, x2), np.maximum(y1, y2))
        hit = (hi >= lo) & (lo > 0)
        t_in[i, hit], t_out[i, hit] = lo[hit], hi[hit]
    return t_in, t_out


def scan_fast(model: LidarModel, azimuths: Array, position: Array, yaw: float | Array,
              blocks: list[Block], ceiling_m: float, max_range_m: float) -> Array:
    """Ranges (m) along each beam, shape (rings, azimuths); inf where nothing is in range. The
    sensor is at `position` (3,) with heading `yaw`, or, for a scan swept while moving, each
    azimuth has its own position (A, 3) and heading (A,)."""
    theta = yaw + azimuths
    z0 = np.broadcast_to(position[..., 2], azimuths.shape)
    t_in, t_out = _box_intervals(position[..., :2], np.cos(theta), np.sin(theta), blocks)
    # only the (block, azimuth) pairs whose 2D ray enters the block can return from it
    blk, col = np.nonzero(np.isfinite(t_in))
    t_in, t_out, z_pair = t_in[blk, col], t_out[blk, col], z0[col]
    heights = np.array([b.size[2] for b in blocks])[blk]
    out = np.empty((len(model.elevations_rad), len(azimuths)))
    for r, phi in enumerate(model.elevations_rad):
        tan = math.tan(phi)
        best = np.full(len(azimuths), np.inf)
        if tan < 0:
            best[:] = z0 / -tan
        elif tan > 0:
            best[:] = (ceiling_m - z0) / tan
        z_in = z_pair + t_in * tan
        side = (z_in >= 0) & (z_in <= heights)
        d = np.where(side, t_in, np.inf)
        if tan < 0:
            d_top = (heights - z_pair) / tan
            top = (z_in > heights) & (d_top <= t_out)
            d = np.where(top, d_top, d)
        np.minimum.at(best, col, d)  # nearest return of each azimuth (min is exact: any order)
        out[r] = best / math.cos(phi)
    out[out > max_range_m] = np.inf
    return out


def scan_reference(client: int, model: LidarModel, azimuths: Array, position: Array,
                   yaw: float, max_range_m: float) -> Array:
    """The same beams through PyBullet's ray test: exact against the simulated bodies."""
    theta = yaw + azimuths
    dirs = []
    for phi in model.elevations_rad:
        dirs.append(np.column_stack([np.cos(phi) * np.cos(theta), np.cos(phi) * np.sin(theta),
                                     np.full(len(theta), np.sin(phi))]))
    d = np.concatenate(dirs)
    ends = position + max_range_m * d
    starts = np.broadcast_to(position, d.shape)
    frac = np.empty(len(d))
    step = pb.MAX_RAY_INTERSECTION_BATCH_SIZE - 1
    for i in range(0, len(d), step):
        hits = pb.rayTestBatch(starts[i:i + step].tolist(), ends[i:i + step].tolist(),
                               physicsClientId=client)
        frac[i:i + step] = [h[2] if h[0] >= 0 else np.inf for h in hits]
    out: Array = (frac * max_range_m).reshape(len(model.elevations_rad), len(azimuths))
    return out


POINT_DTYPE = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("intensity", "<f4"),
                        ("ring", "<u2")])


def to_points(model: LidarModel, azimuths: Array, ranges: Array) -> NDArray[np.void]:
    """Valid returns as a structured array in the sensor frame (x forward, z up)."""
    ring, col = np.nonzero(np.isfinite(ranges))
    r = ranges[ring, col]
    # the cosines of the rings and azimuths, looked up per point rather than computed per point
    cos_phi = np.cos(model.elevations_rad)[ring]
    pts = np.empty(len(r), POINT_DTYPE)
    pts["x"] = r * cos_phi * np.cos(azimuths)[col]
    pts["y"] = r * cos_phi * np.sin(azimuths)[col]
    pts["z"] = r * np.sin(model.elevations_rad)[ring]
    pts["intensity"] = 100.0
    pts["ring"] = ring
    return pts
