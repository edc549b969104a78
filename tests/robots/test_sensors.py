"""The line sensor against the seed's characterisation, and its two implementations."""

from __future__ import annotations

import numpy as np
import pytest

from kartci.robots.line_tracker.characterise import Sweep, sweep
from kartci.scenario import load_scenario

OFFSETS = np.round(np.arange(-0.025, 0.02501, 0.0005), 6)


@pytest.fixture(scope="module")
def geometric_and_rendered() -> tuple[Sweep, Sweep]:
    spec = load_scenario("line_straight")
    return (sweep(spec, "lt0", OFFSETS, mode="geometric"),
            sweep(spec, "lt0", OFFSETS, mode="rendered"))


def test_rendered_and_geometric_sensors_agree(geometric_and_rendered: tuple[Sweep, Sweep]) -> None:
    """Stated tolerance: 0.03 luminance per camera at the default 24 x 24 px (one rendered
    pixel column is 1/24 of the image); the fitted slopes within 5 %."""
    geo, ren = geometric_and_rendered
    assert np.abs(geo.left - ren.left).max() < 0.03
    assert np.abs(geo.right - ren.right).max() < 0.03
    assert ren.fit()[0] == pytest.approx(geo.fit()[0], rel=0.05)


Pair = tuple[Sweep, Sweep]


def test_characterisation_matches_seed_slope_and_linear_range(geometric_and_rendered: Pair
                                                              ) -> None:
    geo, ren = geometric_and_rendered
    for s in (geo, ren):
        slope, intercept, r2 = s.fit(0.008)
        assert slope == pytest.approx(39.4022, rel=0.15)  # seed Eq. 6.12
        assert abs(intercept) < 0.02
        assert r2 > 0.97  # quasi-linear within +-8 mm
    # beyond +-8 mm the difference stops growing (the seed's plateau), then falls to zero
    d = geo.difference
    inside = np.abs(OFFSETS) <= 0.008
    assert np.abs(d[~inside]).max() <= np.abs(d[inside]).max() + 1e-9
    assert abs(d[np.argmin(np.abs(OFFSETS - 0.025))]) < 0.05


def test_each_camera_dims_over_the_line_and_sees_white_far_away(geometric_and_rendered: Pair
                                                                ) -> None:
    geo, _ = geometric_and_rendered
    light = load_scenario("line_straight").world.light_level  # type: ignore[attr-defined]
    assert geo.left[0] == pytest.approx(light) and geo.right[-1] == pytest.approx(light)
    assert geo.left.min() < 0.5 * light
    # the two cameras are 0.01 m apart: their curves are shifted copies of each other
    shift = round(0.01 / 0.0005)
    assert geo.left[:-shift] == pytest.approx(geo.right[shift:], abs=1e-9)


def test_wider_field_of_view_flattens_the_response() -> None:
    spec = load_scenario("line_straight")
    slopes = [sweep(spec, "lt0", OFFSETS, fov_rad=f).fit()[0] for f in (0.75, 1.2, 1.4, 2.0)]
    assert slopes[0] > slopes[1] > slopes[2] > slopes[3]
    assert abs(slopes[3]) < 1.0  # the dead zone beyond 2 atan(12 / 14.5) = 1.38 rad (Eq. 5.2)
