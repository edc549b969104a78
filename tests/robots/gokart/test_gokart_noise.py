"""Sensor errors beyond white noise: statistics as specified, and nothing drawn from the run's
generator when they are off (so scenarios without them keep their numbers)."""

from __future__ import annotations

import numpy as np
import pytest

from kartci.robots.gokart.noise import ImuBias, WheelSlip, dropout
from kartci.robots.gokart.params import ImuSpec, LidarSpec, WheelSpec


def test_errors_that_are_off_draw_nothing() -> None:
    rng = np.random.default_rng(3)
    state = rng.bit_generator.state
    acc, gyro = ImuBias(ImuSpec(), rng, 0.01).sample()
    assert not acc.any() and not gyro.any()
    assert WheelSlip(WheelSpec(), rng, 0.02, 4).apply([1.0, 2.0]) == [1.0, 2.0]
    ranges = np.ones((16, 10))
    assert dropout(ranges, LidarSpec(), rng) is ranges
    assert rng.bit_generator.state == state


def test_imu_bias_is_constant_plus_a_random_walk() -> None:
    """Many runs: the first sample's bias has the constant's sigma; over 10 s at 100 Hz the
    walk adds sigma * sqrt(10 s)."""
    spec = ImuSpec(gyro_bias_std_radps=0.01, gyro_bias_walk_radps_per_sqrt_s=0.001)
    first, last = [], []
    for seed in range(200):
        b = ImuBias(spec, np.random.default_rng(seed), 0.01)
        g0 = b.sample()[1]
        for _ in range(1000):
            g = b.sample()[1]
        first.append(g0)
        last.append(g - g0)
    assert np.std(first) == pytest.approx(0.01, rel=0.1)
    assert np.std(last) == pytest.approx(0.001 * np.sqrt(10.0), rel=0.1)


def test_wheel_slip_has_its_sigma_and_correlation_time() -> None:
    slip = WheelSlip(WheelSpec(slip_std=0.05, slip_corr_s=0.5), np.random.default_rng(0),
                     0.02, 1)
    e = np.array([slip.apply([10.0])[0] / 10.0 - 1.0 for _ in range(50_000)])
    assert np.std(e) == pytest.approx(0.05, rel=0.1)
    lag = 25  # 0.5 s: the correlation falls to 1/e
    assert np.corrcoef(e[:-lag], e[lag:])[0, 1] == pytest.approx(np.exp(-1), abs=0.05)


def test_dropout_loses_the_given_fraction() -> None:
    out = dropout(np.ones((16, 1800)), LidarSpec(dropout_prob=0.1), np.random.default_rng(0))
    assert np.isinf(out).mean() == pytest.approx(0.1, abs=0.005)
