"""The line PID's offset estimate: Eq. 6.13 alone, or the source document's widened range (Sec.
6.3)."""

from __future__ import annotations

import numpy as np

from kartci.project import current as active_project
from kartci.robots.line_tracker.characterise import sweep
from kartci.robots.line_tracker.controllers import LinePidController
from kartci.robots.line_tracker.line_pid import widened
from kartci.scenario import load_scenario


def _estimates() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """True offsets over +-21 mm and the plain and widened estimates from kartci's cameras."""
    offsets = np.round(np.arange(-0.021, 0.02101, 0.0005), 6)
    s = sweep(load_scenario("line_straight",
                            project=active_project()), "lt0", offsets, mode="geometric")
    c = LinePidController()
    plain = c.slope_m * (s.left - s.right) + c.offset_m
    wide = np.array([c.wide_slope_m * (widened(left, right, c.edge_left, c.edge_right)
                                       - c.wide_intercept)
                     for left, right in zip(s.left, s.right, strict=True)])
    return offsets, plain, wide


def test_the_widened_range_reads_the_offset_out_to_21_mm_where_the_difference_folds_back() -> None:
    d, plain, wide = _estimates()
    # the plain difference folds back past about 11 mm: 15 mm reads as less than 8 mm
    assert plain[np.argmin(abs(d - 0.015))] < 0.008
    assert np.any(np.diff(plain[d > 0]) < -1e-4)
    # the widened signal rises with the offset all the way out (Eq. 6.15's +-0.021 m)
    assert np.all(np.diff(wide) > 0)
    outside = np.abs(d) >= 0.001
    assert np.all(np.sign(wide[outside]) == np.sign(d[outside]))
    # continuous at the switch to the camera sum (+-8 mm): no jump bigger than a step's worth
    assert np.max(np.diff(wide)) < 3 * np.median(np.diff(wide))


def test_inside_8_mm_the_widened_signal_is_the_plain_difference() -> None:
    assert widened(0.30, 0.20, 0.4582, 0.1704) == 0.30 - 0.20
    assert widened(0.50, 0.20, 0.4582, 0.1704) == 0.50 + 0.20 - 2 * 0.1704
    assert widened(0.20, 0.50, 0.4582, 0.1704) == -(0.20 + 0.50) + 2 * 0.1704
