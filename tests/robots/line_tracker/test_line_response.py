"""The response metrics on a textbook second-order step, whose overshoot and peak time are known
in closed form, and on a circle's oscillation."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from kartci.metrics import ScoreContext
from kartci.project import current as active_project
from kartci.robots.line_tracker.response import LineResponseParams, response_metrics
from kartci.scenario import load_scenario

ZETA, WN, D0 = 0.3, 3.0, 0.005


def _odom(t: np.ndarray, d: np.ndarray) -> pd.DataFrame:
    """Odometry whose sensor point (0.095 m ahead, heading +x) is `d` left of the line y = 0."""
    return pd.DataFrame({"t": t, "x": 0.2 + 0.1 * t, "y": d, "yaw": np.zeros_like(t),
                         "vx": np.full_like(t, 0.1)})


def _metrics(odom: pd.DataFrame) -> dict[str, float]:
    spec = load_scenario("line_straight_grid", project=active_project())
    ctx = ScoreContext(spec, {"/lt0/odom": odom}, Path("synthetic"), "lt0")
    return {m.name: m.value for m in response_metrics(ctx, LineResponseParams(transient_s=5.0))}


def test_overshoot_and_peak_time_of_a_second_order_release() -> None:
    t = np.arange(0.0, 12.0, 0.002)
    wd = WN * math.sqrt(1 - ZETA**2)
    d = D0 * np.exp(-ZETA * WN * t) * (np.cos(wd * t) + ZETA / math.sqrt(1 - ZETA**2)
                                       * np.sin(wd * t))
    m = _metrics(_odom(t, d))
    assert math.isclose(m["overshoot_ratio"], math.exp(-math.pi * ZETA / math.sqrt(1 - ZETA**2)),
                        rel_tol=1e-3)
    assert math.isclose(m["peak_time_s"], math.pi / wd, abs_tol=0.004)


def test_a_first_order_release_has_no_overshoot() -> None:
    """Only the tail's spread about its median (the end value) shows: well under 0.1 %."""
    t = np.arange(0.0, 12.0, 0.002)
    assert _metrics(_odom(t, D0 * np.exp(-t)))["overshoot_ratio"] < 1e-3


def test_oscillation_amplitude_is_half_the_swing_after_the_transient() -> None:
    t = np.arange(0.0, 12.0, 0.002)
    d = np.where(t < 5.0, 0.004, 0.001 + 0.0005 * np.sin(2 * np.pi * t))
    assert math.isclose(_metrics(_odom(t, d))["oscillation_amplitude_m"], 0.0005, rel_tol=1e-4)
