"""A planar EKF for a kart on a flat floor: state x, y (m), yaw (rad) of base_link in the map,
base_link's lateral velocity vy (m/s, body frame) and the gyroscope's z bias (rad/s).
Predicted at every IMU sample with the wheel speed (vx), the bias-corrected yaw rate and the
lateral acceleration (vy' = a_y - r vx), corrected by each registration's (x, y, yaw).

vy is a state because the kart slides: with Pacejka tyres base_link's lateral speed reaches
several m/s in a corner (localization_lap: mean |vy| 0.68 m/s, peaks 5.8 m/s), and a
zero-lateral-velocity motion model put the estimate decimetres outside the turn between scans.
Our own filter rather than filterpy: the model is a few lines, its Jacobians a few more, and
the yaw innovation must wrap; filterpy's generic EKF would add a dependency for none of that."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

Array = np.ndarray
VY, BIAS = 3, 4  # state indices
VY_PRIOR_STD_MPS = 0.5  # vy before any registration: a kart slides at most a few m/s
SLIP_FRACTION = 0.05  # of the speed: the driven wheels' slip (localization_lap: <= 6.3 %)
# A slip lasts a phase of drive or brake, not one IMU sample: its position error grows with the
# time, where white noise grows with its root. Modelled as white per sample it let the filter
# trust itself 3x too much between scans (IMU at 100 Hz, scans at 10 Hz): on launch and out of
# the last hairpin the gate refused the correct registrations until 5 in a row reset it, and
# whether it refused the first (chi^2 17.1 against 16.27) moved with a 1 nm start change.
SLIP_CORRELATION_S = 0.1


def wrap(angle: float) -> float:
    """An angle in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


@dataclass
class Noise:
    """Process noise of the prediction."""

    wheel_speed_std_mps: float
    gyro_std_radps: float
    bias_walk_radps_per_sqrt_s: float
    accel_std_mps2: float


class PlanarEkf:
    """x, y, yaw, vy, gyro bias with covariance P."""

    def __init__(self, x: float, y: float, yaw: float, std_xy_m: float, std_yaw_rad: float,
                 noise: Noise) -> None:
        """Start at the guess with its uncertainty; vy at zero (0.5 m/s sigma), the bias at
        zero (0.01 rad/s sigma)."""
        self.s = np.array([x, y, yaw, 0.0, 0.0])
        self.P = np.diag([std_xy_m**2, std_xy_m**2, std_yaw_rad**2, VY_PRIOR_STD_MPS**2, 0.01**2])
        self.noise = noise

    def predict(self, v_mps: float, gyro_radps: float, dt_s: float,
                lat_accel_mps2: float = 0.0) -> None:
        """Move by (wheel speed, vy) in the heading's frame, turn by the corrected rate and
        change vy by the lateral acceleration of base_link less the turn's r vx."""
        if dt_s <= 0:
            return
        x, y, yaw, vy, bias = self.s
        c, s = math.cos(yaw), math.sin(yaw)
        r = gyro_radps - bias
        self.s = np.array([x + (v_mps * c - vy * s) * dt_s, y + (v_mps * s + vy * c) * dt_s,
                           wrap(yaw + r * dt_s), vy + (lat_accel_mps2 - r * v_mps) * dt_s,
                           bias])
        F = np.eye(5)
        F[0, 2], F[1, 2] = -(v_mps * s + vy * c) * dt_s, (v_mps * c - vy * s) * dt_s
        F[0, VY], F[1, VY] = -s * dt_s, c * dt_s
        F[2, BIAS], F[VY, BIAS] = -dt_s, v_mps * dt_s
        n = self.noise
        slip = SLIP_FRACTION * abs(v_mps) * math.sqrt(max(SLIP_CORRELATION_S / dt_s, 1.0))
        sv = n.wheel_speed_std_mps + slip
        # inputs: wheel speed, gyro rate, lateral acceleration
        G = np.zeros((5, 3))
        G[0, 0], G[1, 0] = c * dt_s, s * dt_s
        G[2, 1], G[VY, 1] = dt_s, -v_mps * dt_s
        G[VY, 2] = dt_s
        Q = G @ np.diag([sv**2, n.gyro_std_radps**2, n.accel_std_mps2**2]) @ G.T
        Q[BIAS, BIAS] += n.bias_walk_radps_per_sqrt_s**2 * dt_s
        self.P = F @ self.P @ F.T + Q

    def innovation(self, z: Array) -> tuple[Array, Array]:
        """Innovation of a pose measurement (x, y, yaw) and its covariance without R."""
        r = z - self.s[:3]
        r[2] = wrap(float(r[2]))
        return r, self.P[:3, :3]

    def mahalanobis2(self, z: Array, R: Array) -> float:
        """Squared Mahalanobis distance of a pose measurement."""
        r, S = self.innovation(z)
        return float(r @ np.linalg.solve(S + R, r))

    def update(self, z: Array, R: Array) -> None:
        """Correct with a pose measurement (x, y, yaw) of covariance R."""
        r, S = self.innovation(z)
        K = self.P[:, :3] @ np.linalg.inv(S + R)
        self.s = self.s + K @ r
        self.s[2] = wrap(float(self.s[2]))
        IKH = np.eye(5)
        IKH[:, :3] -= K
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T  # Joseph form: stays symmetric PSD

    def reset(self, z: Array, R: Array) -> None:
        """Jump to a pose (relocalization), keeping the bias estimate. vy starts again from its
        prior (0, 0.5 m/s sigma): while the filter was lost its registrations were gated out, so
        vy was integrated open loop from the accelerometer and kept a wrong drift (0.5 m/s off in
        localization_kidnap) that the small reset covariance would not let the next scans fix."""
        bias_var = self.P[BIAS, BIAS]
        self.s[:3] = z
        self.s[VY] = 0.0
        self.P = np.zeros((5, 5))
        self.P[:3, :3] = R
        self.P[VY, VY] = VY_PRIOR_STD_MPS**2
        self.P[BIAS, BIAS] = bias_var

