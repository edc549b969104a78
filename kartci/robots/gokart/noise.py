"""Sensor errors beyond white noise, all drawn from the run's one seeded generator and all off
by default (so scenarios written before them keep their numbers): IMU bias (constant + random
walk), wheel slip in the reported wheel speeds, lidar dropout and motion distortion."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from kartci.robots.gokart.params import ImuSpec, LidarSpec, WheelSpec
from kartci.sim.body import BodyState

Array = np.ndarray


class ImuBias:
    """Accelerometer and gyroscope bias: a constant drawn at the first sample, then a random
    walk (rate random walk in the usual Allan-variance terms)."""

    def __init__(self, spec: ImuSpec, rng: np.random.Generator, period_s: float) -> None:
        """Nothing is drawn until the first sample, and nothing at all when all are zero."""
        self.spec, self.rng, self.period_s = spec, rng, period_s
        self.acc: Array | None = None
        self.gyro: Array | None = None
        self.active = any(v > 0 for v in (spec.accel_bias_std_mps2, spec.gyro_bias_std_radps,
                                          spec.accel_bias_walk_mps2_per_sqrt_s,
                                          spec.gyro_bias_walk_radps_per_sqrt_s))

    def sample(self) -> tuple[Array, Array]:
        """The biases to add to this sample (specific force m/s^2, rate rad/s), then walk."""
        if not self.active:
            return np.zeros(3), np.zeros(3)
        s = self.spec
        if self.acc is None or self.gyro is None:
            self.acc = s.accel_bias_std_mps2 * self.rng.standard_normal(3)
            self.gyro = s.gyro_bias_std_radps * self.rng.standard_normal(3)
        out = self.acc.copy(), self.gyro.copy()
        root = math.sqrt(self.period_s)
        self.acc = self.acc + s.accel_bias_walk_mps2_per_sqrt_s * root * (
            self.rng.standard_normal(3))
        self.gyro = self.gyro + s.gyro_bias_walk_radps_per_sqrt_s * root * (
            self.rng.standard_normal(3))
        return out


class WheelSlip:
    """Relative wheel-speed error per wheel, first-order Gauss-Markov, stepped at the odometry
    rate."""

    def __init__(self, spec: WheelSpec, rng: np.random.Generator, period_s: float,
                 wheels: int) -> None:
        """Zero slip to start; `wheels` processes."""
        self.spec, self.rng = spec, rng
        self.decay = math.exp(-period_s / spec.slip_corr_s)
        self.kick = spec.slip_std * math.sqrt(1.0 - self.decay**2)
        self.slip = np.zeros(wheels)

    def apply(self, speeds: list[float]) -> list[float]:
        """The speeds as the wheel encoders report them."""
        if self.spec.slip_std == 0.0:
            return speeds
        self.slip = self.decay * self.slip + self.kick * self.rng.standard_normal(len(speeds))
        return [float(v * (1.0 + e)) for v, e in zip(speeds, self.slip, strict=True)]


SECTORS = 36  # a revolution is cast from this many poses (10 degrees each)


def distorted_scan(scan: Callable[[Array, Array, Array], Array], azimuths: Array,
                   st: BodyState, sensor_xyz: Array, rate_hz: float) -> Array:
    """Ranges (rings, azimuths) with each sector cast from the pose the sensor had when the head
    pointed there: the revolution ends at the stamp, azimuth a was swept (1 - a / 2 pi) / rate
    earlier; the pose is taken back along the current body twist. `scan(azimuths, positions,
    yaws)` casts the beams, each azimuth from its own position (A, 3) and heading (A,), in
    one call."""
    w_world = st.rotation @ np.asarray(st.w_body)
    v_sensor = st.rotation @ np.asarray(st.v_body) + np.cross(
        w_world, sensor_xyz - np.asarray(st.xyz))
    xyz, yaw = np.empty((len(azimuths), 3)), np.empty(len(azimuths))
    for part in np.array_split(np.arange(len(azimuths)), SECTORS):
        ago_s = (1.0 - float(azimuths[part].mean()) / (2 * math.pi)) / rate_hz
        xyz[part] = sensor_xyz - v_sensor * ago_s
        yaw[part] = st.yaw - w_world[2] * ago_s
    return scan(azimuths, xyz, yaw)


def dropout(ranges: Array, spec: LidarSpec, rng: np.random.Generator) -> Array:
    """Returns lost at random (no echo): inf, as for nothing in range."""
    if spec.dropout_prob == 0.0:
        return ranges
    lost = rng.random(ranges.shape) < spec.dropout_prob
    return np.where(lost, np.inf, ranges)
