"""`kartci map`: the point-cloud map of a world from a mapping run of the simulated lidar, as
the real team built theirs from Velodyne data (source document 000, Sec. 5.2).

The mapping run places the lidar at the kart's sensor height every `step_m` along the track's
centreline, heading along the track, and once more offset to each side (so walls behind pillars
are seen), casts full revolutions with the sensor's range noise, puts the points into the world
frame at the run's poses and keeps one point per voxel. The poses are the simulator's (the real
team's came from a mapping SLAM run): the map carries the sensor's noise, not a pose error. The
world's own obstacles are mapped; a scenario's added ones are not (a map is made once, for the
hall, before anything is placed on the track)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from kartci import core
from kartci.core import WorldParams
from kartci.errors import SpecError
from kartci.pointcloud import voxel_downsample, write_ply
from kartci.sim import lidar as lidar_mod
from kartci.worlds.track.world import TrackWorld

SENSOR_HEIGHT_M = 1.28  # bumblebee's velodyne_link above the floor (URDF 1.154 m + wheel)


@dataclass(frozen=True)
class MapRun:
    """How a map is made (each is written into the PLY's comments)."""

    lidar: str = "vlp16"
    step_m: float = 1.0
    side_m: float = 1.0
    voxel_m: float = 0.2
    seed: int = 0


def build_map(world: WorldParams, run: MapRun = MapRun()) -> np.ndarray:
    """World-frame points (N, 3), m, of a mapping run through `world`."""
    if run.lidar not in lidar_mod.MODELS:
        raise SpecError(f"lidar '{run.lidar}': expected one of {', '.join(lidar_mod.MODELS)}")
    if not 0.05 <= run.voxel_m <= 2.0 or not 0.1 <= run.step_m <= 20.0:
        raise SpecError("map: voxel must be in [0.05, 2] m and step in [0.1, 20] m")
    sim = core.WORLDS.get(world.kind).factory(world, 0.01)
    try:
        if not isinstance(sim, TrackWorld):
            raise SpecError(f"world kind {world.kind}: a map needs a world with a track")
        blocks, ceiling, track = list(sim.blocks), sim.ceiling_m, sim.track
    finally:
        sim.close()
    model = lidar_mod.MODELS[run.lidar]
    azimuths = model.azimuths(10.0)
    rng = np.random.default_rng(run.seed)
    clouds = []
    for s in np.arange(0.0, track.length_m, run.step_m):
        for lateral in (0.0, run.side_m, -run.side_m):
            x, y, yaw = track.pose_at(float(s), lateral)
            pos = np.array([x, y, SENSOR_HEIGHT_M])
            ranges = lidar_mod.scan_fast(model, azimuths, pos, yaw, blocks, ceiling, 100.0)
            ranges = ranges + model.range_accuracy_m * rng.standard_normal(ranges.shape)
            pts = lidar_mod.to_points(model, azimuths, ranges)
            c, sn = math.cos(yaw), math.sin(yaw)
            px, py = pts["x"].astype(float), pts["y"].astype(float)
            clouds.append(np.column_stack([x + c * px - sn * py, y + sn * px + c * py,
                                           SENSOR_HEIGHT_M + pts["z"].astype(float)]))
    return voxel_downsample(np.concatenate(clouds), run.voxel_m)


def save_map(world: WorldParams, name: str, out: Path, run: MapRun = MapRun()) -> int:
    """Build the map of `world` and write it to `out` (PLY); the number of points."""
    xyz = build_map(world, run)
    write_ply(out, xyz, f"kartci map of {name}: world frame, m\nmapping run: lidar {run.lidar}, "
              f"step {run.step_m} m, side {run.side_m} m, voxel {run.voxel_m} m, "
              f"seed {run.seed}")
    return len(xyz)
