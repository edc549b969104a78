"""The kart's IMU in scalar arithmetic gives numpy's bits (the formula it replaced), for an IMU
mounted turned and off the centre, so the scalar sums' order is held for any mount."""

from __future__ import annotations

import numpy as np

from kartci._bullet import pb
from kartci.project import current as active_project
from kartci.robots.gokart.robot import KartRobot
from kartci.scenario import load_scenario
from kartci.sim.session import Session


def _numpy_imu(robot: KartRobot, prev: np.ndarray, rel: np.ndarray,
               rel_rot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The IMU before the scalar form (kartci at eab3d56), noise and bias left out."""
    st = robot.body.state()
    rot = st.rotation
    w_world = rot @ np.asarray(st.w_body)
    v_world = rot @ np.asarray(st.v_body) + np.cross(w_world, rot @ rel)
    acc = (v_world - prev) / (robot.imu_every * robot.dt)
    to_imu = (rot @ rel_rot).T
    return to_imu @ (acc + np.array([0.0, 0.0, 9.81])), to_imu @ w_world


def test_the_scalar_imu_equals_numpys_products() -> None:
    spec = load_scenario("kart_manual", ["duration_s=2",
                                         "agents.kart0.sensors.imu.accel_noise_std_mps2=0",
                                         "agents.kart0.sensors.imu.gyro_noise_std_radps=0"],
                                         project=active_project())
    with Session(spec, None) as s:
        s.reset()
        robot = s.world.robots[0]
        assert isinstance(robot, KartRobot)
        rng = np.random.default_rng(3)
        for _ in range(8):
            for _ in range(100):  # the kart drives on between the checks
                s.step()
            rel = rng.uniform(-1.0, 1.0, 3)
            quat = rng.normal(size=4)
            rel_rot = np.array(pb.getMatrixFromQuaternion((quat / np.linalg.norm(quat)).tolist()
                                                          )).reshape(3, 3)
            prev = rng.normal(size=3)
            robot._imu_mount = ((rel[0], rel[1], rel[2]), rel_rot.tolist())
            robot._imu_prev = tuple(prev.tolist())
            got: list[object] = []
            robot._imu(robot.body.state(), s.t_ns,
                       lambda topic, m, t, record=True, into=got: into.append(m))
            f, g = _numpy_imu(robot, prev, rel, rel_rot)
            imu = got[0]
            a, w = imu.linear_acceleration, imu.angular_velocity  # type: ignore[attr-defined]
            assert [a.x, a.y, a.z, w.x, w.y, w.z] == [*f.tolist(), *g.tolist()]
