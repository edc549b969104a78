"""The kart plant's parts, each against its closed form: the simulated body weighs what the
parameters say (kartci/robots/gokart/inertia.py)."""

from __future__ import annotations

import pytest

from kartci._bullet import pb
from kartci.errors import SpecError
from kartci.robots.gokart.body import Gokart
from kartci.robots.gokart.params import GokartModel, cog_x_m
from kartci.scenario import project_root

MODELS = project_root() / "kartci" / "data" / "models" / "gokart"
NOMINAL = GokartModel()


def _whole_body(model: GokartModel) -> tuple[float, float, float, float]:
    """Mass (kg), centre of mass x and z in base_link (m) and yaw inertia about it (kg m^2) of
    the loaded body, from PyBullet's dynamics info of every link."""
    c = pb.connect(pb.DIRECT)
    try:
        kart = Gokart(c, model, MODELS, (0.0, 0.0, 0.0), 0.002)
        base = kart.state().xyz
        links = []  # mass, CoM (x, y, z) relative to base_link, own izz
        for link in range(-1, pb.getNumJoints(kart.body, physicsClientId=c)):
            info = pb.getDynamicsInfo(kart.body, link, physicsClientId=c)
            com = (pb.getBasePositionAndOrientation(kart.body, physicsClientId=c)[0] if link < 0
                   else pb.getLinkState(kart.body, link, physicsClientId=c)[0])
            links.append((info[0], com[0] - base[0], com[1] - base[1], com[2] - base[2],
                          info[2][2]))
    finally:
        pb.disconnect(c)
    mass = sum(m for m, *_ in links)
    x = sum(m * lx for m, lx, *_ in links) / mass
    z = sum(m * lz for m, _, _, lz, _ in links) / mass
    izz = sum(i + m * ((lx - x) ** 2 + ly**2) for m, lx, ly, _, i in links)
    return mass, x, z, izz


@pytest.mark.parametrize("overrides", [{}, {"mass_kg": 340.0, "yaw_inertia_kgm2": 26.0,
                                            "cog_to_rear_axle_m": 0.5, "cog_height_m": 0.3}])
def test_the_simulated_body_has_the_parameters_mass_properties(overrides: dict[str, float],
                                                               ) -> None:
    model = NOMINAL.model_copy(update=overrides)
    mass, x, z, izz = _whole_body(model)
    assert mass == pytest.approx(model.mass_kg, abs=1e-6)
    assert x == pytest.approx(cog_x_m(model), abs=1e-6)
    assert z == pytest.approx(model.cog_height_m - model.rear_wheel_radius_m, abs=1e-6)
    assert izz == pytest.approx(model.yaw_inertia_kgm2, abs=1e-6)


@pytest.mark.parametrize(("field", "value", "message"), [
    ("mass_kg", 5.0, "model.mass_kg: 5 kg is no more than the wheels and steer links alone "
     "(9 kg)"),
    ("yaw_inertia_kgm2", 1.0, "model.yaw_inertia_kgm2: 1 kg m^2 is no more than the wheels and "
     "steer links give alone (6.06 kg m^2)")])
def test_impossible_mass_properties_are_one_line(field: str, value: float, message: str) -> None:
    c = pb.connect(pb.DIRECT)
    try:
        with pytest.raises(SpecError) as err:
            Gokart(c, NOMINAL.model_copy(update={field: value}), MODELS, (0.0, 0.0, 0.0), 0.002)
    finally:
        pb.disconnect(c)
    assert str(err.value) == message
