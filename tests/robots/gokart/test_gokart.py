"""The go-kart against the source document's tables, its lidar against PyBullet's rays, and its
runs."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from kartci._bullet import pb
from kartci.metrics import compute
from kartci.project import current as active_project
from kartci.robots.gokart import KartInput, wheel_angles
from kartci.robots.gokart.body import Gokart
from kartci.robots.gokart.params import GokartModel
from kartci.scenario import load_scenario
from kartci.sim import lidar, simulate
from kartci.worlds.hall import HallWorld
from kartci.worlds.hall.world import Hall as World
from kartci.worlds.hall.world import blocks

MODELS = active_project().root / "models" / "gokart"
TABLE_3_2 = {  # joint: (type, axis, parent, child, translation)
    "cog_joint": ("fixed", None, "base_link", "cog_link", (0.36, 0.0, 0.0)),
    "rear_left_wheel_joint": ("continuous", "y", "base_link", "rear_left_wheel_link",
                              (-0.077, 0.5625, 0.0)),
    "rear_right_wheel_joint": ("continuous", "y", "base_link", "rear_right_wheel_link",
                               (-0.077, -0.5625, 0.0)),
    "front_left_wheel_steer_joint": ("revolute", "z", "base_link",
                                     "front_left_wheel_steer_link", (1.129, 0.47, -0.015)),
    "front_left_wheel_joint": ("continuous", "y", "front_left_wheel_steer_link",
                               "front_left_wheel_link", (0.0, 0.0, 0.0)),
    "front_right_wheel_steer_joint": ("revolute", "z", "base_link",
                                      "front_right_wheel_steer_link", (1.129, -0.47, -0.015)),
    "front_right_wheel_joint": ("continuous", "y", "front_right_wheel_steer_link",
                                "front_right_wheel_link", (0.0, 0.0, 0.0)),
}
TABLE_3_4 = {  # variant: frame -> (xyz, rpy)
    "bumblebee": {"imu_link": ((0.78, 0.26, 0.08), (0, 0, 0)),
                  "velodyne_link": ((0.0, 0.0, 1.154), (0, 0, 0)),
                  "camera_link": ((0.0, 0.0, 0.875), (-math.pi / 2, 0, -math.pi / 2))},
    "herbie": {"imu_link": ((0.745, 0.0, 0.08), (0, 0, 0)),
               "velodyne_link": ((0.0, 0.0, 1.2), (0, 0, 0)),
               "camera_link": ((0.0, 0.0, 0.875), (-math.pi / 2, 0, -math.pi / 2))},
}
TABLE_3_3_BETA_C = [-1.8448, -1.6815, -1.524, -1.3642, -1.2013, -1.0339, -0.8847, -0.7292,
                    -0.2688, -0.372, -0.2065, -0.0717, 0.0836, 0.2009, 0.3862, 0.5606, 0.7308,
                    0.882, 1.0411, 1.1932, 1.3541, 1.5208, 1.6865, 1.7319]


@pytest.mark.parametrize("variant", ["bumblebee", "herbie"])
def test_urdf_joints_and_sensor_frames_match_the_tables(variant: str) -> None:
    c = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(str(MODELS / f"{variant}.urdf"), physicsClientId=c)
        types = {pb.JOINT_FIXED: "fixed", pb.JOINT_REVOLUTE: "revolute"}
        joints = {}
        for j in range(pb.getNumJoints(body, physicsClientId=c)):
            info = pb.getJointInfo(body, j, physicsClientId=c)
            state = pb.getLinkState(body, j, computeForwardKinematics=True, physicsClientId=c)
            joints[info[1].decode()] = (info, state)
        # the base link frame sits at the origin, unrotated, all joints at zero: a link frame's
        # world position is its parent's plus the joint's translation
        world = {"base_link": (0.0, 0.0, 0.0)}
        world.update({info[12].decode(): state[4] for info, state in joints.values()})
        for name, (kind, axis, parent, child, xyz) in TABLE_3_2.items():
            info, _ = joints[name]
            assert info[12].decode() == child
            parent_idx = info[16]
            assert (parent_idx == -1 and parent == "base_link") or (
                pb.getJointInfo(body, parent_idx, physicsClientId=c)[12].decode() == parent)
            got = np.subtract(world[child], world[parent])
            assert got == pytest.approx(xyz, abs=5e-4)  # to the millimetre
            if kind == "continuous":  # PyBullet reports continuous joints as revolute
                assert info[2] == pb.JOINT_REVOLUTE and info[8] > info[9]  # no limits
            else:
                assert types[info[2]] == kind
            if axis:
                assert info[13] == pytest.approx({"y": (0, 1, 0), "z": (0, 0, 1)}[axis])
        for frame, (xyz, rpy) in TABLE_3_4[variant].items():
            _, state = joints[frame.replace("_link", "_joint")]
            assert state[4] == pytest.approx(xyz, abs=5e-4)
            expected = pb.getQuaternionFromEuler(rpy)
            assert abs(float(np.dot(state[5], expected))) == pytest.approx(1.0, abs=1e-6)
    finally:
        pb.disconnect(c)


def _kart(steering: str = "measured") -> tuple[World, Gokart, GokartModel]:
    spec = load_scenario("kart_replay", [f"agents.kart0.model.steering={steering}"],
                         project=active_project())
    assert isinstance(spec.world, HallWorld)
    model = spec.agents["kart0"].model
    assert isinstance(model, GokartModel)
    world = World(spec.world, 0.002)
    return world, Gokart(world.client, model, MODELS, (8.0, 3.2, 0.0), 0.002), model  # start line


@pytest.mark.parametrize("steering", ["measured", "ackermann"])
def test_steering_wheel_angles_of_table_3_3_give_eq_3_4_and_3_5(steering: str) -> None:
    world, kart, model = _kart(steering)
    try:
        for beta in TABLE_3_3_BETA_C:
            kart.command(KartInput(steering_rad=beta))
            for _ in range(600):  # 1.2 s: the column slews at 4 rad/s, then the joints settle
                kart.pre_step()
                world.step()
            (left, right), _, _ = kart.wheel_states()
            exp_left, exp_right = wheel_angles(model, beta)
            assert (left, right) == pytest.approx((exp_left, exp_right), abs=2e-3), beta
    finally:
        world.close()
    # by hand, mirrored left-right to kartci's left-positive column (gokart.wheel_angles): the
    # source document's right wheel (Eq. 3.2, 3.4) is the inner, left wheel of a left turn
    if steering == "measured":  # Eq. 3.4 at beta_C = 1.0
        assert wheel_angles(model, 1.0)[0] == pytest.approx(-0.0355 + 0.0455 + 0.36)
    else:  # Eq. 3.2, l = 1.27, w = 0.94, centre wheel 0.36 x 1.0 rad
        t = math.tan(0.36)
        assert wheel_angles(model, 1.0)[0] == pytest.approx(math.atan(1.27 * t / (1.27 - 0.47 * t)))
    left, right = wheel_angles(model, 1.0)
    assert left > right > 0  # a left turn: the inner wheel turns more (Ackermann sense)


@pytest.mark.parametrize(("name", "rings", "lowest", "highest", "spacing", "per_rev"), [
    ("vlp16", 16, -15.0, 15.0, 2.0, 1800),  # 0.2 deg at 10 Hz
    ("hdl32e", 32, -30.67, 10.67, 1.333, 2182),  # 0.165 deg at 10 Hz
])
def test_lidar_models_follow_table_3_5(name: str, rings: int, lowest: float, highest: float,
                                       spacing: float, per_rev: int) -> None:
    m = lidar.MODELS[name]
    deg = np.degrees(m.elevations_rad)
    assert len(deg) == rings
    assert (deg[0], deg[-1]) == pytest.approx((lowest, highest), abs=0.01)
    assert np.diff(deg) == pytest.approx(np.full(rings - 1, spacing), abs=0.002)
    assert len(m.azimuths(10.0)) == per_rev
    assert len(m.azimuths(5.0)) == pytest.approx(2 * per_rev, rel=0.01)


@pytest.mark.parametrize("name", ["vlp16", "hdl32e"])
def test_fast_lidar_agrees_with_pybullet_rays(name: str) -> None:
    spec = load_scenario("kart_replay", ["world.obstacles=[{center_m: [14, 3.2], "
                                         "size_m: [0.6, 0.6, 0.5]}]"], project=active_project())
    assert isinstance(spec.world, HallWorld)
    world = World(spec.world, 0.002)
    try:
        m = lidar.MODELS[name]
        az = m.azimuths(10.0)
        for x, y, yaw in ((8.0, 3.2, 0.0), (25.0, 9.0, 2.0), (5.0, 14.0, -1.0)):
            pos = np.array([x, y, 0.127 + 1.154])
            fast = lidar.scan_fast(m, az, pos, yaw, blocks(spec.world), spec.world.wall_height_m,
                               100.0)
            ref = lidar.scan_reference(world.client, m, az, pos, yaw, 100.0)
            both = np.isfinite(fast) & np.isfinite(ref)
            assert (np.isfinite(fast) == np.isfinite(ref)).mean() > 0.999
            assert (np.abs(fast[both] - ref[both]) < 0.01).mean() > 0.995
    finally:
        world.close()


def _run(tmp_path: Path, name: str, *sets: str) -> dict[str, float]:
    log = tmp_path / f"{name}.mcap"
    simulate(load_scenario(name, list(sets), project=active_project()), log)
    return {k: v.value for k, v in compute(log)[1].items()}


@pytest.mark.long(reason="several robot runs")
def test_kart_manual_completes_its_laps_without_collisions(tmp_path: Path) -> None:
    m = _run(tmp_path, "kart_manual")
    assert m["laps_completed"] == 2
    assert m["collisions"] == 0
    assert m["off_track_s"] == 0
    assert 12.0 < m["best_lap_s"] < 20.0


def test_steering_into_a_wall_is_a_collision(tmp_path: Path) -> None:
    log = tmp_path / "crash.mcap"
    spec = load_scenario("kart_replay", [
        "duration_s=8", "agents.kart0.controller.steps=[{t_s: 0, accel_mps2: 3.0}, "
        "{t_s: 1.0, steering_rad: -1.7, accel_mps2: 2.0}]"], project=active_project())
    simulate(spec, log)
    _, metrics = compute(log)
    assert metrics["collisions"].value >= 1
    first = metrics["collisions"].extra["events"][0]
    assert first["other"] == "wall_south"
    assert first["impulse_ns"] > 10.0


@pytest.mark.long(reason="several robot runs")
def test_the_slippery_zone_changes_the_drive(tmp_path: Path) -> None:
    """The same joystick inputs on concrete everywhere vs. with the coated (mu 0.6) east end,
    then with the east end at mu 0.3: the kart slides wide on the slipperiest floor."""
    concrete = _run(tmp_path, "kart_manual", "world.zones=[]")
    coated = _run(tmp_path, "kart_manual")
    icy = _run(tmp_path, "kart_manual", "world.zones=[{name: icy, min_m: [24, 0], "
                                         "max_m: [32, 20], friction: 0.3}]")
    assert concrete["cross_track_rms_m"] != coated["cross_track_rms_m"]
    assert icy["off_track_s"] > concrete["off_track_s"] + 0.5 or icy["collisions"] > 0


def test_imu_reads_gravity_at_rest(tmp_path: Path) -> None:
    from kartci.logs import tables

    log = tmp_path / "rest.mcap"
    simulate(load_scenario("kart_replay", ["duration_s=2",
                                           "agents.kart0.sensors.imu.accel_noise_std_mps2=0"],
                                           project=active_project()), log)
    imu = tables(log, ["/kart0/imu"])["/kart0/imu"]
    assert len(imu) == 201  # 100 Hz over 2 s, both ends
    settled = imu[imu["t"] > 1.0]
    assert settled["az"].mean() == pytest.approx(9.81, abs=0.02)
    assert settled["ax"].abs().max() < 0.05
    noisy = tables(_noisy(tmp_path), ["/kart0/imu"])["/kart0/imu"]
    assert noisy[noisy["t"] > 1.0]["az"].std() == pytest.approx(0.01 * 8 * 9.81, rel=0.25)


def _noisy(tmp_path: Path) -> Path:
    log = tmp_path / "noisy.mcap"
    simulate(load_scenario("kart_replay", ["duration_s=2"], project=active_project()), log)
    return log


def test_camera_and_moving_frames(tmp_path: Path) -> None:
    from kartci.logs import messages

    log = tmp_path / "cam.mcap"
    simulate(load_scenario("kart_replay", ["duration_s=1",
                                           "agents.kart0.sensors.camera.enabled=true"],
                                           project=active_project()), log)
    images = [m for _, _, m in messages(log, ["/kart0/camera/image_raw"])]
    assert len(images) == 6  # 5 Hz over 1 s, both ends
    img = np.asarray(images[-1].data).reshape(60, 80, 3)
    assert img.std() > 10  # walls and floor, not a blank frame
    frames = {t.child_frame_id for _, _, m in messages(log, ["/tf"]) for t in m.transforms}
    assert {"kart0/base_link", "kart0/front_left_wheel_steer_link",
            "kart0/rear_right_wheel_link", "kart0/front_left_wheel_link"} <= frames
    static = {t.child_frame_id for _, _, m in messages(log, ["/tf_static"]) for t in m.transforms}
    assert static == {"kart0/cog_link", "kart0/imu_link", "kart0/velodyne_link",
                      "kart0/camera_link"}


def test_reverse_and_emergency_stop() -> None:
    world, kart, _ = _kart()
    try:
        def drive(cmd: KartInput, seconds: float) -> float:
            kart.command(cmd)
            for _ in range(round(seconds / 0.002)):
                kart.pre_step()
                world.step()
            return kart.state().v_body[0]

        assert drive(KartInput(accel_mps2=2.0, reverse=True), 1.5) < -1.5  # backwards
        assert drive(KartInput(brake_mps2=8.0), 1.0) == pytest.approx(0.0, abs=0.05)
        assert drive(KartInput(accel_mps2=4.0), 1.5) > 3.0
        # the e-stop brakes at the largest deceleration (max_brake_mps2) on all four wheels
        assert drive(KartInput(accel_mps2=4.0, estop=True), 2.0) == pytest.approx(0.0, abs=0.05)
    finally:
        world.close()


@pytest.mark.parametrize("mapping", ["ps4", "g29"])
def test_joystick_mappings_round_trip(mapping: str) -> None:
    from kartci.robots.gokart.joy import load_mapping, to_command, to_joy

    m = load_mapping(mapping, active_project().model_path)
    model = load_scenario("kart_replay", project=active_project()).agents["kart0"].model
    assert isinstance(model, GokartModel)
    wish = KartInput(steering_rad=-0.9, accel_mps2=2.5, brake_mps2=0.0, reverse=True)
    got = to_command(m, model, to_joy(m, model, wish, 0, "joy"))
    assert got.steering_rad == pytest.approx(wish.steering_rad, abs=1e-6)
    assert got.accel_mps2 == pytest.approx(2.5, abs=1e-5)
    assert (got.brake_mps2, got.reverse, got.estop) == (0.0, True, False)


@pytest.mark.parametrize("variant", ["bumblebee", "herbie"])
def test_urdf_mass_properties_are_the_params(variant: str) -> None:
    """The URDF's links add up to params.yaml's mass, centre of mass (0.46 m ahead of the rear
    axle, REFERENCE.md) and yaw inertia (20 kg m^2), as PyBullet loads them."""
    model = GokartModel()
    c = pb.connect(pb.DIRECT)
    try:
        body = pb.loadURDF(str(MODELS / f"{variant}.urdf"), flags=pb.URDF_USE_INERTIA_FROM_FILE,
                           physicsClientId=c)
        links = []  # mass, world CoM (x, y), own izz
        for link in range(-1, pb.getNumJoints(body, physicsClientId=c)):
            info = pb.getDynamicsInfo(body, link, physicsClientId=c)
            com = (pb.getBasePositionAndOrientation(body, physicsClientId=c)[0] if link < 0
                   else pb.getLinkState(body, link, physicsClientId=c)[0])
            links.append((info[0], com[0], com[1], info[2][2]))
        mass = sum(m for m, _, _, _ in links)
        x = sum(m * lx for m, lx, _, _ in links) / mass
        izz = sum(i + m * ((lx - x) ** 2 + ly**2) for m, lx, ly, i in links)
    finally:
        pb.disconnect(c)
    assert mass == pytest.approx(model.mass_kg, abs=0.01)
    assert x - model.wheel_xy_m[0][0] == pytest.approx(model.cog_to_rear_axle_m, abs=1e-3)
    assert izz == pytest.approx(model.yaw_inertia_kgm2, rel=0.01)
