"""Deprecated: import from `kartci.robots.gokart` (the kart's command, steering map and
outline live with the kart). Kept so that code written against `kartci.vehicle` keeps working;
nothing in kartci imports it."""

from typing import Any

from kartci.robots import gokart
from kartci.robots.gokart import (
    STEERING_RATIO,
    GokartModel,
    KartInput,
    axle_distance_m,
    column_for_wheel_angle,
    speed_to_pedals,
    steer_for_turn_rate,
    wheel_angles,
)

__all__ = ["STEERING_RATIO", "GokartModel", "KartInput", "axle_distance_m",
           "column_for_wheel_angle", "speed_to_pedals", "steer_for_turn_rate", "wheel_angles"]


def __getattr__(name: str) -> Any:
    """`FOOTPRINT_M`, computed from the kart's URDF when asked for (kartci.robots.gokart's)."""
    if name == "FOOTPRINT_M":
        return gokart.FOOTPRINT_M
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
