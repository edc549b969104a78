"""Deprecated: import from `kartci.robots.gokart` (the kart's command, steering map and
outline live with the kart). Kept so that code written against `kartci.vehicle` keeps working;
nothing in kartci imports it. `FOOTPRINT_M` is computed from the kart's URDF on import here."""

from kartci.robots.gokart import (
    FOOTPRINT_M,
    STEERING_RATIO,
    GokartModel,
    KartInput,
    axle_distance_m,
    column_for_wheel_angle,
    speed_to_pedals,
    steer_for_turn_rate,
    wheel_angles,
)

__all__ = ["FOOTPRINT_M", "STEERING_RATIO", "GokartModel", "KartInput", "axle_distance_m",
           "column_for_wheel_angle", "speed_to_pedals", "steer_for_turn_rate", "wheel_angles"]
