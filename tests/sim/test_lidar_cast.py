"""The fast lidar's batched forms give exactly what the one-pose cast gives."""

from __future__ import annotations

import math

import numpy as np

from kartci.project import current as active_project
from kartci.robots.gokart.noise import SECTORS, distorted_scan
from kartci.scenario import load_scenario
from kartci.sim import lidar
from kartci.sim.body import BodyState
from kartci.worlds.hall import HallWorld
from kartci.worlds.hall.world import blocks

VLP16 = lidar.MODELS["vlp16"]
AZ = VLP16.azimuths(10.0)


def _hall() -> HallWorld:
    world = load_scenario("kart_replay", project=active_project()).world
    assert isinstance(world, HallWorld)
    return world


def test_a_pose_per_azimuth_equal_to_one_pose_is_the_one_pose_scan() -> None:
    world = _hall()
    bl, pos = blocks(world), np.array([8.0, 3.2, 1.28])
    one = lidar.scan_fast(VLP16, AZ, pos, 0.3, bl, world.wall_height_m, 100.0)
    each = lidar.scan_fast(VLP16, AZ, np.tile(pos, (len(AZ), 1)), np.full(len(AZ), 0.3), bl,
                           world.wall_height_m, 100.0)
    assert np.isfinite(one).mean() > 0.9  # walls, floor and pillars all around
    np.testing.assert_array_equal(each, one)


def test_a_distorted_scan_is_each_sector_cast_from_its_own_pose() -> None:
    """One batched cast equals the sectors cast one by one from their poses."""
    world = _hall()
    bl, pos, yaw = blocks(world), np.array([8.0, 3.2, 1.28]), 0.3
    st = BodyState((8.0, 3.2, 0.127), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)),
                   (8.0, 0.3, 0.0), (0.0, 0.0, 1.2))

    def cast(a: np.ndarray, p: np.ndarray, h: float | np.ndarray) -> np.ndarray:
        return lidar.scan_fast(VLP16, a, p, h, bl, world.wall_height_m, 100.0)

    got = distorted_scan(cast, AZ, st, pos, 10.0)
    parts = np.array_split(np.arange(len(AZ)), SECTORS)
    first, last = parts[0], parts[-1]
    rot = st.rotation
    w = rot @ np.asarray(st.w_body)
    v = rot @ np.asarray(st.v_body) + np.cross(w, pos - np.asarray(st.xyz))
    for part in (first, last):
        ago = (1.0 - float(AZ[part].mean()) / (2 * math.pi)) / 10.0
        want = cast(AZ[part], pos - v * ago, st.yaw - w[2] * ago)
        np.testing.assert_array_equal(got[:, part], want)
    assert not np.array_equal(got, cast(AZ, pos, yaw))  # the sweep moved the sensor
