"""The localization node's parts against physics and geometry: deskewing undoes the simulated
motion distortion, the EKF integrates and corrects as its model says, registration to the
shipped map finds a scan's true pose from an offset guess."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from kartci.localization.deskew import deskew
from kartci.localization.ekf import Noise, PlanarEkf
from kartci.localization.registration import MapMatcher, pose_matrix
from kartci.project import current as active_project
from kartci.robots.gokart.noise import distorted_scan
from kartci.scenario.load import load_world
from kartci.sim import lidar
from kartci.sim.blocks import Block
from kartci.sim.body import BodyState
from kartci.worlds.hall import HallWorld
from kartci.worlds.hall.world import blocks

VLP16 = lidar.MODELS["vlp16"]
AZ = VLP16.azimuths(10.0)


def hall_map() -> Path:
    """The hall's point-cloud map (`kartci map winti/hall`)."""
    return active_project().world_file("winti/hall_map.ply")


def _hall() -> tuple[list[Block], float]:
    world, _ = load_world("winti/hall", active_project())
    assert isinstance(world, HallWorld)
    return blocks(world), world.wall_height_m


def _xyz(ranges: np.ndarray) -> np.ndarray:
    pts = lidar.to_points(VLP16, AZ, ranges)
    return np.column_stack([pts["x"], pts["y"], pts["z"]]).astype(float)


def _state(x: float, y: float, yaw: float, v: float, w: float, vy: float = 0.0) -> BodyState:
    return BodyState((x, y, 0.13), (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)),
                     (v, vy, 0.0), (0.0, 0.0, w))


def test_deskew_undoes_motion_distortion() -> None:
    """At 7 m/s and 1 rad/s, a distorted scan's walls sit decimetres off the scan taken at the
    stamp; deskewed with the true twist they sit within a few centimetres."""
    bl, ceiling = _hall()
    st = _state(12.0, 4.0, 0.3, 7.0, 1.0)
    pos = np.array([12.0, 4.0, 1.28])

    def scan(az: np.ndarray, xyz: np.ndarray, yaw: float | np.ndarray) -> np.ndarray:
        return lidar.scan_fast(VLP16, az, xyz, yaw, bl, ceiling, 100.0)

    truth = cKDTree(_xyz(scan(AZ, pos, st.yaw)))
    raw = _xyz(distorted_scan(scan, AZ, st, pos, 10.0))
    walls = np.abs(raw[:, 2]) < 1.0  # beams about level: walls and pillars, not floor
    before = np.median(truth.query(raw[walls])[0])
    after = np.median(truth.query(deskew(raw, 7.0, 1.0, 10.0)[walls])[0])
    assert before > 0.05
    assert after < 0.03


def test_deskew_undoes_a_sideways_slide() -> None:
    """Sliding at 5 m/s forward and 3 m/s sideways at 2 rad/s (the new plant's corners):
    deskewed with the lateral velocity the walls sit within a few centimetres of the scan at
    the stamp; deskewed as if vy were zero they sit several centimetres further off."""
    bl, ceiling = _hall()
    st = _state(12.0, 4.0, 0.3, 5.0, 2.0, vy=3.0)
    pos = np.array([12.0, 4.0, 1.28])

    def scan(az: np.ndarray, xyz: np.ndarray, yaw: float | np.ndarray) -> np.ndarray:
        return lidar.scan_fast(VLP16, az, xyz, yaw, bl, ceiling, 100.0)

    truth = cKDTree(_xyz(scan(AZ, pos, st.yaw)))
    raw = _xyz(distorted_scan(scan, AZ, st, pos, 10.0))
    walls = np.abs(raw[:, 2]) < 1.0
    with_vy = np.median(truth.query(deskew(raw, 5.0, 2.0, 10.0, vy_mps=3.0)[walls])[0])
    without = np.median(truth.query(deskew(raw, 5.0, 2.0, 10.0)[walls])[0])
    assert with_vy < 0.03
    assert without > with_vy + 0.03


def test_deskew_at_standstill_is_the_identity() -> None:
    xyz = np.random.default_rng(0).normal(size=(100, 3))
    assert np.allclose(deskew(xyz, 0.0, 0.0, 10.0), xyz)


def _ekf() -> PlanarEkf:
    return PlanarEkf(0.0, 0.0, 0.0, 0.5, 0.1, Noise(0.05, 0.02, 0.001, 0.1))


def test_ekf_prediction_drives_the_circle_of_its_inputs() -> None:
    """2 m/s at 0.5 rad/s for 2 pi s, the IMU feeling the 1 m/s^2 centripetal acceleration:
    half a circle of radius 4 m, to (0, 8), heading pi, no slide."""
    f = _ekf()
    for _ in range(6283):
        f.predict(2.0, 0.5, 0.001, lat_accel_mps2=1.0)
    assert f.s[0] == pytest.approx(0.0, abs=0.01)
    assert f.s[1] == pytest.approx(8.0, abs=0.01)
    assert abs(abs(f.s[2]) - math.pi) < 0.002
    assert f.P[0, 0] > 0.25  # uncertainty only grows without measurements


def test_ekf_learns_the_gyro_bias_from_registrations() -> None:
    """A gyro reading 0.02 rad/s too high at standstill and a registration saying the heading
    stays 0: the bias state converges to 0.02 rad/s."""
    f = _ekf()
    r = np.diag([0.01**2, 0.01**2, 0.003**2])
    for _ in range(300):  # 30 s: 10 predictions per registration
        for _ in range(10):
            f.predict(0.0, 0.02, 0.01)
        assert f.mahalanobis2(np.zeros(3), r) < 100
        f.update(np.zeros(3), r)
    assert f.s[4] == pytest.approx(0.02, abs=0.002)
    assert abs(f.s[2]) < 0.005


def test_ekf_integrates_lateral_acceleration() -> None:
    """At rest, heading 0: 1 m/s^2 sideways for 1 s is 1 m/s of vy and 0.5 m of y; in a turn
    at 5 m/s and 1 rad/s, a lateral acceleration of exactly r vx keeps vy at zero."""
    f = _ekf()
    for _ in range(1000):
        f.predict(0.0, 0.0, 0.001, lat_accel_mps2=1.0)
    assert f.s[3] == pytest.approx(1.0, abs=1e-9)
    assert f.s[1] == pytest.approx(0.5, abs=1e-3)
    assert f.s[0] == pytest.approx(0.0, abs=1e-9)
    g = _ekf()
    for _ in range(1000):
        g.predict(5.0, 1.0, 0.001, lat_accel_mps2=5.0)
    assert g.s[3] == pytest.approx(0.0, abs=1e-9)


def test_ekf_learns_a_slide_from_registrations() -> None:
    """A kart sliding sideways at 2 m/s while the IMU says nothing of it (its lateral
    acceleration was missed): registrations every 0.1 s teach the filter vy within 0.1 m/s
    and keep the position within 2 cm."""
    f = _ekf()
    r = np.diag([0.01**2, 0.01**2, 0.003**2])
    for k in range(1, 51):
        for _ in range(10):
            f.predict(0.0, 0.0, 0.01)
        f.update(np.array([0.0, 0.2 * k, 0.0]), r)
    assert f.s[3] == pytest.approx(2.0, abs=0.1)
    assert f.s[1] == pytest.approx(10.0, abs=0.02)


def test_registration_finds_the_true_pose_from_an_offset_guess() -> None:
    """A noisy scan at a known pose, registered to the shipped map from 0.4 m and 3 degrees
    off: within 3 cm and 0.3 degrees of the truth."""
    bl, ceiling = _hall()
    x, y, yaw = 20.0, 4.5, 0.4
    ranges = lidar.scan_fast(VLP16, AZ, np.array([x, y, 1.28]), yaw, bl, ceiling, 100.0)
    ranges = ranges + 0.03 * np.random.default_rng(1).standard_normal(ranges.shape)
    matcher = MapMatcher.from_file(hall_map(), 0.2, "GICP", 1.0, 30)
    m = matcher.align(_xyz(ranges), 0.3, pose_matrix(x + 0.3, y - 0.25, 1.2, yaw + 0.05))
    assert m.converged
    assert math.hypot(m.xy_yaw[0] - x, m.xy_yaw[1] - y) < 0.03
    assert abs(m.xy_yaw[2] - yaw) < math.radians(0.3)
    assert m.inlier_ratio > 0.8


def test_ekf_relocalization_forgets_the_slide_it_dead_reckoned_while_lost() -> None:
    """Settled by 5 s of registrations, then lost for 0.5 s (five 10 Hz scans gated out) while
    the IMU reads 1.2 m/s^2 of lateral acceleration the kart did not have: vy is 0.6 m/s off.
    After the jump onto the registrations (covariance 4 R, as the node does) the kart drives
    straight at 5 m/s without sliding: every following registration passes the gate (chi2 16.27)
    and vy returns to 0. Keeping the dead-reckoned vy with its settled covariance gated the next
    scans out (localization_kidnap's second divergence event)."""
    f = _ekf()
    r = np.diag([0.01**2, 0.01**2, 0.003**2])
    x = 0.0
    for _ in range(50):
        for _ in range(10):
            f.predict(5.0, 0.0, 0.01)
            x += 0.05
        f.update(np.array([x, 0.0, 0.0]), r)
    for _ in range(50):
        f.predict(5.0, 0.0, 0.01, lat_accel_mps2=1.2)
        x += 0.05
    assert f.s[3] == pytest.approx(0.6, abs=0.01)
    f.reset(np.array([x, 0.0, 0.0]), 4 * r)
    for _ in range(10):  # 1 s of registrations on the true straight line
        for _ in range(10):
            f.predict(5.0, 0.0, 0.01)
            x += 0.05
        z = np.array([x, 0.0, 0.0])
        assert f.mahalanobis2(z, r) <= 16.27
        f.update(z, r)
    assert abs(f.s[3]) < 0.05
    assert abs(f.s[1]) < 0.02
