"""The kart's public API for a team's own controller (docs/howto/plugins.md, the kart's API):
`kartci.robots.gokart` exports the command, the steering map and the parameter set, its
`outline` module the outline from the URDF, and the map and its inverse agree."""

from __future__ import annotations

import pytest

import kartci.robots.gokart as kart
from kartci.project import BUILTIN_MODELS
from kartci.scenario.yamlio import read_yaml

DOCUMENTED = {"KartInput", "wheel_angles", "column_for_wheel_angle", "steer_for_turn_rate",
              "STEERING_RATIO", "speed_to_pedals", "GokartModel",
              "axle_distance_m", "KartSensors"}


def test_the_documented_kart_api_is_exported() -> None:
    from kartci.robots.gokart import outline

    assert set(kart.__all__) >= DOCUMENTED
    assert all(hasattr(kart, name) for name in kart.__all__)
    assert {"outline", "half_width_m", "footprint_m"} <= set(dir(outline))
    assert not hasattr(kart, "FOOTPRINT_M")  # the old constant: `outline.footprint_m(model)`


@pytest.mark.parametrize("wheel_rad", [-0.4, -0.1, 0.0, 0.2, 0.4])
def test_the_steering_map_and_its_inverse_agree(wheel_rad: float) -> None:
    model = kart.GokartModel.model_validate(read_yaml(BUILTIN_MODELS / "gokart" / "params.yaml"))
    column = kart.column_for_wheel_angle(model, wheel_rad)
    left, right = kart.wheel_angles(model, column)
    assert (left + right) / 2 == pytest.approx(wheel_rad, abs=1e-9)
