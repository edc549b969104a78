"""A planar EKF for a kart on a flat floor: state x, y (m), yaw (rad) of base_link in the map
and the gyroscope's z bias (rad/s). Predicted at every IMU sample with the wheel speed and the
bias-corrected yaw rate, corrected by each registration's (x, y, yaw).

Our own 4-state filter rather than filterpy: the model is four lines, its Jacobians two, and
the yaw innovation must wrap; filterpy's generic EKF would add a dependency for none of that."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

Array = np.ndarray


def wrap(angle: float) -> float:
    """An angle in [-pi, pi)."""
    return (angle + math.pi) % (2 * math.pi) - math.pi


@dataclass
class Noise:
    """Process noise of the prediction."""

    wheel_speed_std_mps: float
    gyro_std_radps: float
    bias_walk_radps_per_sqrt_s: float
    lateral_slip_std_mps: float


class PlanarEkf:
    """x, y, yaw, gyro bias with covariance P."""

    def __init__(self, x: float, y: float, yaw: float, std_xy_m: float, std_yaw_rad: float,
                 noise: Noise) -> None:
        """Start at the guess with its uncertainty; the bias at zero, 0.01 rad/s sigma."""
        self.s = np.array([x, y, yaw, 0.0])
        self.P = np.diag([std_xy_m**2, std_xy_m**2, std_yaw_rad**2, 0.01**2])
        self.noise = noise

    def predict(self, v_mps: float, gyro_radps: float, dt_s: float) -> None:
        """Move by the wheel speed along the heading and turn by the corrected rate."""
        if dt_s <= 0:
            return
        x, y, yaw, bias = self.s
        c, s = math.cos(yaw), math.sin(yaw)
        self.s = np.array([x + v_mps * c * dt_s, y + v_mps * s * dt_s,
                           wrap(yaw + (gyro_radps - bias) * dt_s), bias])
        F = np.eye(4)
        F[0, 2], F[1, 2], F[2, 3] = -v_mps * s * dt_s, v_mps * c * dt_s, -dt_s
        n = self.noise
        sv = n.wheel_speed_std_mps + 0.05 * abs(v_mps)
        G = np.array([[c * dt_s, -s * dt_s, 0.0], [s * dt_s, c * dt_s, 0.0],
                      [0.0, 0.0, dt_s], [0.0, 0.0, 0.0]])
        Q = G @ np.diag([sv**2, n.lateral_slip_std_mps**2, n.gyro_std_radps**2]) @ G.T
        Q[3, 3] += n.bias_walk_radps_per_sqrt_s**2 * dt_s
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
        IKH = np.eye(4)
        IKH[:, :3] -= K
        self.P = IKH @ self.P @ IKH.T + K @ R @ K.T  # Joseph form: stays symmetric PSD

    def reset(self, z: Array, R: Array) -> None:
        """Jump to a pose (relocalization), keeping the bias estimate."""
        self.s[:3] = z
        self.P[:3, :3] = R
        self.P[:3, 3] = self.P[3, :3] = 0.0

    def shift(self, dx: float, dy: float) -> None:
        """Move the estimate without touching P (a kidnap the filter is not told about)."""
        self.s[0] += dx
        self.s[1] += dy
