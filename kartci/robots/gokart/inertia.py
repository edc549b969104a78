"""The kart's mass properties, one source: the parameters' mass, centre of mass and yaw inertia.

The chassis link (base_link) is weighed so that the whole body (chassis, wheels, steer links)
adds up to them: `make_urdf.py` writes the shipped URDFs' chassis with it, and the simulated
body is loaded with its chassis re-weighed from the scenario's parameters (so `--set
agents.kart0.model.mass_kg=340` is a heavier kart, not only heavier tyre loads).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from kartci.errors import SpecError
from kartci.robots.gokart.params import GokartModel, cog_x_m
from kartci.sim.urdf import rpy_matrix

BOX_M = (1.8, 1.2, 0.3)  # roll and pitch inertia: a box of these proportions, scaled to izz


@dataclass(frozen=True)
class PointMass:
    """A link's mass (kg), centre of mass in base_link (m) and own yaw inertia (kg m^2)."""

    mass_kg: float
    xyz_m: tuple[float, float, float]
    izz_kgm2: float


@dataclass(frozen=True)
class Inertial:
    """The chassis link's inertial: mass (kg), centre of mass in base_link (x, z; m) and
    principal inertia about it (kg m^2)."""

    mass_kg: float
    x_m: float
    z_m: float
    ixx_kgm2: float
    iyy_kgm2: float
    izz_kgm2: float


def chassis_inertial(model: GokartModel, others: list[PointMass]) -> Inertial:
    """The chassis inertial that gives the whole kart (chassis and `others`) the model's mass,
    centre of mass and yaw inertia (parallel-axis theorem). base_link sits at the rear wheel
    centre height (Table 3.2), so the CoM is `cog_height_m - rear_wheel_radius_m` above it."""
    total, x_cog = model.mass_kg, cog_x_m(model)
    z_cog = model.cog_height_m - model.rear_wheel_radius_m
    m_o = sum(o.mass_kg for o in others)
    m_c = total - m_o
    if m_c <= 0:
        raise SpecError(f"model.mass_kg: {total:g} kg is no more than the wheels and steer "
                        f"links alone ({m_o:g} kg)")
    x_c = (total * x_cog - sum(o.mass_kg * o.xyz_m[0] for o in others)) / m_c
    z_c = (total * z_cog - sum(o.mass_kg * o.xyz_m[2] for o in others)) / m_c
    izz_o = sum(o.izz_kgm2 + o.mass_kg * ((o.xyz_m[0] - x_cog) ** 2 + o.xyz_m[1] ** 2)
                for o in others)
    izz_c = model.yaw_inertia_kgm2 - izz_o - m_c * (x_c - x_cog) ** 2
    if izz_c <= 0:
        raise SpecError(f"model.yaw_inertia_kgm2: {model.yaw_inertia_kgm2:g} kg m^2 is no more "
                        f"than the wheels and steer links give alone "
                        f"({model.yaw_inertia_kgm2 - izz_c:.3g} kg m^2)")
    lx, wy, hz = BOX_M
    k = izz_c / (m_c * (lx**2 + wy**2) / 12)
    return Inertial(m_c, x_c, z_c, k * m_c * (wy**2 + hz**2) / 12, k * m_c * (lx**2 + hz**2) / 12,
                    izz_c)


def _origin(element: ET.Element) -> tuple[np.ndarray, np.ndarray]:
    """Translation and rotation of an element's <origin> (identity if it has none)."""
    origin = element.find("origin")
    xyz, rpy = ("0 0 0", "0 0 0") if origin is None else (origin.get("xyz", "0 0 0"),
                                                           origin.get("rpy", "0 0 0"))
    return np.fromstring(xyz, sep=" "), rpy_matrix(*np.fromstring(rpy, sep=" "))


def link_masses(root: ET.Element, base: str = "base_link") -> list[PointMass]:
    """Every link of a URDF but `base`, as a point mass with its own yaw inertia, placed in
    base's frame through the joints' origins (joints at zero)."""
    parent: dict[str, tuple[str, ET.Element]] = {}
    for joint in root.iter("joint"):
        p, c = joint.find("parent"), joint.find("child")
        if p is not None and c is not None:
            parent[c.get("link", "")] = (p.get("link", ""), joint)

    def pose(link: str) -> tuple[np.ndarray, np.ndarray]:
        if link not in parent:
            return np.zeros(3), np.eye(3)
        up, joint = parent[link]
        pos, rot = pose(up)
        xyz, r = _origin(joint)
        return pos + rot @ xyz, rot @ r

    out = []
    for link in root.iter("link"):
        name, inertial = link.get("name", ""), link.find("inertial")
        mass = None if inertial is None else inertial.find("mass")
        if name == base or inertial is None or mass is None:
            continue
        pos, rot = pose(name)
        xyz, r = _origin(inertial)
        tensor = inertial.find("inertia")
        diag = np.diag([float(tensor.get(k, "0")) if tensor is not None else 0.0
                        for k in ("ixx", "iyy", "izz")])
        world = rot @ r
        centre = pos + rot @ xyz
        out.append(PointMass(float(mass.get("value", "0")),
                             (float(centre[0]), float(centre[1]), float(centre[2])),
                             float((world @ diag @ world.T)[2, 2])))
    return out


def weigh_chassis(model: GokartModel) -> Callable[[ET.Element], None]:
    """A URDF edit: base_link's inertial set so the whole body has the model's mass properties."""

    def edit(root: ET.Element) -> None:
        base = next((link for link in root.iter("link") if link.get("name") == "base_link"),
                    None)
        if base is None:
            raise SpecError("a go-kart URDF needs a base_link")
        c = chassis_inertial(model, link_masses(root))
        for old in base.findall("inertial"):
            base.remove(old)
        inertial = ET.Element("inertial")
        ET.SubElement(inertial, "origin", xyz=f"{c.x_m!r} 0 {c.z_m!r}")
        ET.SubElement(inertial, "mass", value=repr(c.mass_kg))
        ET.SubElement(inertial, "inertia", ixx=repr(c.ixx_kgm2), iyy=repr(c.iyy_kgm2),
                      izz=repr(c.izz_kgm2), ixy="0", ixz="0", iyz="0")
        base.insert(0, inertial)

    return edit
