"""Write the Bumblebee and Herbie URDFs from the seed's tables (run once; URDFs are the data).

Frames and joints: Table 3.2 (joints), Table 3.4 (sensors), Table 3.1 (tire radii). Mass, centre
of mass and yaw inertia come from params.yaml (Table 3.1 and REFERENCE.md, cited there): the
chassis link gets whatever mass, position and yaw inertia make the whole kart (chassis, wheels,
steer links, frames) add up to them. Simple shapes stand in for the meshes.
"""

from __future__ import annotations

from pathlib import Path

from kartci.scenario.yamlio import read_yaml

Vec = tuple[float, float, float]
# imu_link and velodyne_link translations (Table 3.4)
VARIANTS: dict[str, tuple[Vec, Vec]] = {
    "bumblebee": ((0.78, 0.26, 0.08), (0.0, 0.0, 1.154)),
    "herbie": ((0.745, 0.0, 0.08), (0.0, 0.0, 1.2)),
}
REAR_R, FRONT_R, TIRE_MASS, STEER_MASS, FRAME_MASS = 0.127, 0.117, 2.0, 0.5, 0.01
REAR_X, FRONT_X, REAR_Y, FRONT_Y = -0.077, 1.129, 0.5625, 0.47  # Table 3.2
PARAMS = read_yaml(Path(__file__).with_name("params.yaml"))


def _others() -> list[tuple[float, float, float, float, float]]:
    """(mass, x, y, z, own izz) of every link but the chassis."""
    out = []
    for x, y, r, w, extra in ((REAR_X, REAR_Y, REAR_R, 0.2, 0.0),
                              (FRONT_X, FRONT_Y, FRONT_R, 0.13, 1.0)):
        for side in (1, -1):
            out.append((TIRE_MASS, x, side * y, -0.015 * extra,
                        TIRE_MASS * (3 * r**2 + w**2) / 12))
            if extra:
                out.append((STEER_MASS, x, side * y, -0.015, 1e-3))
    return out


def chassis_inertial() -> tuple[float, float, float, float]:
    """Chassis mass, CoM x and z in base_link, and yaw inertia about its CoM, such that the
    whole kart has params.yaml's mass, CoM and yaw inertia (parallel-axis theorem)."""
    total, lr = PARAMS["mass_kg"], PARAMS["cog_to_rear_axle_m"]
    x_cog, z_cog = REAR_X + lr, PARAMS["cog_height_m"] - REAR_R
    others = _others()
    n_frames = 4  # cog, imu, velodyne, camera links: negligible, counted in the mass only
    m_c = total - sum(o[0] for o in others) - n_frames * FRAME_MASS
    x_c = (total * x_cog - sum(o[0] * o[1] for o in others)) / m_c
    z_c = (total * z_cog - sum(o[0] * o[3] for o in others)) / m_c
    izz_others = sum(o[4] + o[0] * ((o[1] - x_cog) ** 2 + o[2] ** 2) for o in others)
    izz_c = PARAMS["yaw_inertia_kgm2"] - izz_others - m_c * (x_c - x_cog) ** 2
    return m_c, x_c, z_c, izz_c


def inertial(mass: float, ixx: float, iyy: float, izz: float, xyz: str = "0 0 0") -> str:
    return (f'    <inertial><origin xyz="{xyz}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx:.4g}" iyy="{iyy:.4g}" izz="{izz:.4g}" ixy="0" ixz="0" iyz="0"/>'
            "</inertial>")


def fixed(name: str, xyz: tuple[float, float, float], rpy: str = "0 0 0") -> str:
    return (f'  <link name="{name}">\n{inertial(0.01, 1e-5, 1e-5, 1e-5)}\n  </link>\n'
            f'  <joint name="{name.removesuffix("_link")}_joint" type="fixed"><parent '
            f'link="base_link"/><child link="{name}"/><origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" '
            f'rpy="{rpy}"/></joint>')


def wheel(name: str, parent: str, xyz: str, radius: float, width: float, axis_joint: str) -> str:
    i_axle = TIRE_MASS * radius**2 / 2
    i_other = TIRE_MASS * (3 * radius**2 + width**2) / 12
    return (f'  <link name="{name}_link">\n{inertial(TIRE_MASS, i_other, i_axle, i_other)}\n'
            f'    <collision><geometry><sphere radius="{radius}"/></geometry></collision>\n'
            f'    <visual><origin rpy="1.5707963 0 0"/><geometry><cylinder radius="{radius}" '
            f'length="{width}"/></geometry><material name="tire"/></visual>\n  </link>\n'
            f'  <joint name="{name}_joint" type="{axis_joint}"><parent link="{parent}"/>'
            f'<child link="{name}_link"/><origin xyz="{xyz}"/><axis xyz="0 1 0"/>'
            '<limit effort="95" velocity="100"/></joint>')


def steer(side: str, y: float) -> str:
    return (f'  <link name="front_{side}_wheel_steer_link">\n{inertial(0.5, 1e-3, 1e-3, 1e-3)}'
            f'\n  </link>\n  <joint name="front_{side}_wheel_steer_joint" type="revolute">'
            f'<parent link="base_link"/><child link="front_{side}_wheel_steer_link"/>'
            f'<origin xyz="1.129 {y} -0.015"/><axis xyz="0 0 1"/>'
            '<limit lower="-0.9" upper="0.9" effort="500" velocity="6"/></joint>\n'
            + wheel(f"front_{side}_wheel", f"front_{side}_wheel_steer_link", "0 0 0", FRONT_R,
                    0.13, "continuous"))


def urdf(name: str, imu: Vec, velodyne: Vec) -> str:
    chassis, cog_x, cog_z, izz = chassis_inertial()
    lx, wy, hz = 1.8, 1.2, 0.3  # roll and pitch: a box of these proportions, scaled to izz
    k = izz / (chassis * (lx**2 + wy**2) / 12)
    return f"""<?xml version="1.0"?>
<!-- Go-kart "{name}" of the seed "A Comprehensive Gazebo Simulation for the Autonomous Racing
     GoKart Research Platform". base_link: x forward, y left, z up, at the rear wheel centre
     height (Table 3.2 puts the rear wheel joints at z = 0). Joint origins: Table 3.2; sensor
     frames: Table 3.4; tire radii: Table 3.1; total mass, centre of mass and yaw inertia:
     params.yaml (Table 3.1, REFERENCE.md). Roll and pitch inertia: a {lx} x {wy} x {hz} m box's,
     scaled to the yaw inertia. Wheel collisions are spheres of the tire radius (one contact
     point each). Generated by make_urdf.py. -->
<robot name="{name}">
  <material name="body"><color rgba="0.95 0.75 0.1 1"/></material>
  <material name="tire"><color rgba="0.1 0.1 0.1 1"/></material>
  <link name="base_link">
{inertial(round(chassis, 3), k * chassis * (wy**2 + hz**2) / 12,
          k * chassis * (lx**2 + hz**2) / 12, izz, f"{cog_x:.4f} 0 {cog_z:.4f}")}
    <collision><origin xyz="0.6 0 0.06"/><geometry><box size="2.0 1.2 0.25"/></geometry>
    </collision>
    <visual><origin xyz="0.6 0 0.06"/><geometry><box size="2.0 1.0 0.25"/></geometry>
      <material name="body"/></visual>
  </link>
{fixed("cog_link", (0.36, 0.0, 0.0))}
{wheel("rear_left_wheel", "base_link", "-0.077 0.5625 0.0", REAR_R, 0.2, "continuous")}
{wheel("rear_right_wheel", "base_link", "-0.077 -0.5625 0.0", REAR_R, 0.2, "continuous")}
{steer("left", 0.47)}
{steer("right", -0.47)}
{fixed("imu_link", imu)}
{fixed("velodyne_link", velodyne)}
{fixed("camera_link", (0.0, 0.0, 0.875), "-1.5707963 0 -1.5707963")}
</robot>
"""


def main() -> None:
    for name, (imu, velodyne) in VARIANTS.items():
        out = Path(__file__).with_name(f"{name}.urdf")
        out.write_text(urdf(name, imu, velodyne), encoding="utf-8")
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
