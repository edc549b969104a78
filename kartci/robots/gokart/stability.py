"""The kart's stability in a turn: the linear single-track model's critical speed, and the
warning a scenario gets when its kart may drive faster than that.

With ETH's tyre curves (front B 9, C 1; rear B 5.2, C 1.1: REFERENCE.md, the only figures
published for the kart, the rear included) and the centre of mass 0.46 m ahead of the rear axle,
the front axle is the stiffer per kg of load and the kart oversteers: above the critical speed a
small disturbance grows into a spin, wheel centred. Whether the real kart does is not known (no
source gives its rear tyre beyond those figures): that is the assumption a scenario is warned of.
"""

from __future__ import annotations

import math

from kartci.robots.gokart.mpcc.reference import DEFAULT_FLOOR_FRICTION
from kartci.robots.gokart.params import (
    GRAVITY_MPS2,
    PDY1,
    GokartModel,
    Tyre,
    axle_distance_m,
)

CONTROLLER_SPEED_LIMITS = ("max_speed_mps", "target_speed_mps")  # a controller's own, m/s


def cornering_stiffness_per_kg(tyre: Tyre, mu: float) -> float:
    """A tyre's cornering stiffness at its static load per kg of that load, m/s^2 per rad:
    B C D with D = mu g (dfz = 0)."""
    return tyre.b * tyre.c * mu * PDY1 * GRAVITY_MPS2


def critical_speed_mps(model: GokartModel, mu: float) -> float:
    """The speed above which the linear single-track model is unstable (oversteer), m/s, on
    a floor of friction `mu` (times `tire_friction`); inf for a kart that understeers.

    Axle stiffnesses C_f = k_f m l_r / L, C_r = k_r m l_f / L (k the per-kg stiffness of
    `cornering_stiffness_per_kg`, l_f and l_r the CoM to the front and rear axle):
    v_crit^2 = C_f C_r L^2 / (m (C_f l_f - C_r l_r)), real when C_f l_f > C_r l_r. The masses
    cancel: v_crit^2 = L k_f k_r / (k_f - k_r), so v_crit grows as sqrt(mu)."""
    grip = mu * model.tire_friction
    k_f = cornering_stiffness_per_kg(model.front_tyre, grip)
    k_r = cornering_stiffness_per_kg(model.rear_tyre, grip)
    length, l_r = axle_distance_m(model), model.cog_to_rear_axle_m
    l_f, m = length - l_r, model.mass_kg
    c_f, c_r = k_f * m * l_r / length, k_r * m * l_f / length
    excess = c_f * l_f - c_r * l_r
    if excess <= 0.0:
        return math.inf
    return math.sqrt(c_f * c_r * length**2 / (m * excess))


def lowest_friction(world: object) -> float:
    """The lowest friction coefficient of a world's floor and zones (dimensionless): where
    the critical speed is lowest."""
    floor = float(getattr(world, "floor_friction", DEFAULT_FLOOR_FRICTION))
    return min([floor, *(float(z.friction) for z in getattr(world, "zones", ()))])


def speed_limit_mps(model: GokartModel, controller: object) -> float:
    """The fastest the agent is set to drive, m/s: the kart's governor (`max_speed_mps`), or
    its controller's own limit or target where that is lower."""
    own = [float(v) for name in CONTROLLER_SPEED_LIMITS
           if isinstance(v := getattr(controller, name, None), int | float)]
    return min([model.max_speed_mps, *own])


def speed_warnings(model: object, controller: object, world: object) -> list[str]:
    """One warning when the agent's speed limit exceeds the critical speed on the world's
    slipperiest floor (`RobotKind.warnings`)."""
    if not isinstance(model, GokartModel):
        return []
    mu = lowest_friction(world)
    limit, critical = speed_limit_mps(model, controller), critical_speed_mps(model, mu)
    if limit <= critical:
        return []
    return [f"speed limit {limit:g} m/s exceeds the kart's critical speed {critical:.1f} m/s "
            f"(oversteer: linear single-track model at mu {mu * model.tire_friction:g}, "
            "rear tyre an assumption; see kartci/robots/gokart/stability.py): above it the "
            "kart can spin with the wheel centred"]
