"""The go-kart as a PyBullet multibody: its chassis weighed to the parameters' mass properties
(inertia.py), tyre forces from a slip model (tyres.py) applied at the wheels' contact points
every physics step, position-controlled steer joints through the measured steering map, and
wheels spun at their road speed and slip (for odometry and looks; their contacts have no
friction and only carry the weight)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kartci._bullet import pb, quiet_c_output
from kartci.robots.gokart.inertia import weigh_chassis
from kartci.robots.gokart.params import GokartModel
from kartci.robots.gokart.steering import KartInput, wheel_angles
from kartci.robots.gokart.tyres import (
    air_drag_n,
    drive_demand,
    normal_loads,
    wheel_force,
    wheels,
)
from kartci.sim.body import Base, BodyState
from kartci.sim.urdf import fixed_frames, physics_urdf

WHEEL_SPIN_TORQUE_NM = 20.0  # spins the (frictionless) wheels at their rolling speed


class Gokart(Base):
    """The kart's PyBullet body: the latest command, clamped to the model's limits, becomes joint
    motor targets before every physics step."""

    def __init__(self, client: int, model: GokartModel, model_dir: Path,
                 pose: tuple[float, float, float], dt_s: float) -> None:
        self.model, self.dt = model, dt_s
        x, y, yaw = pose
        with quiet_c_output():
            body = int(pb.loadURDF(
                str(physics_urdf(model_dir / model.urdf, weigh_chassis(model))),
                [x, y, model.rear_wheel_radius_m + 0.005], pb.getQuaternionFromEuler([0, 0, yaw]),
                flags=pb.URDF_USE_INERTIA_FROM_FILE, physicsClientId=client))
        super().__init__(client, body, fixed_frames(model_dir / model.urdf))
        joints = {pb.getJointInfo(self.body, j, physicsClientId=client)[1].decode(): j
                  for j in range(pb.getNumJoints(self.body, physicsClientId=client))}
        self.rear = [joints["rear_left_wheel_joint"], joints["rear_right_wheel_joint"]]
        self.front = [joints["front_left_wheel_joint"], joints["front_right_wheel_joint"]]
        self.steer = [joints["front_left_wheel_steer_joint"],
                      joints["front_right_wheel_steer_joint"]]
        self.wheels = [*self.rear, *self.front]
        # no velocity damping (Bullet's default 0.04): tyres.py models rolling and air drag
        pb.changeDynamics(self.body, -1, linearDamping=0.0, angularDamping=0.0,
                          physicsClientId=client)
        for link in self.wheels:  # the tyre model makes every horizontal force
            pb.changeDynamics(self.body, link, lateralFriction=0.0, rollingFriction=0.0,
                              spinningFriction=0.0, physicsClientId=client)
        self.tyres = wheels(model)
        self.accel = (0.0, 0.0)  # body-frame acceleration of the last step's forces, m/s^2
        self.mu_scale = [1.0] * 4
        self.input = KartInput()
        self.column = 0.0  # steering-column angle, rad
        self._steer_target: tuple[float, float] | None = None  # last steer-motor targets, rad
        # per wheel (rl, rr, fl, fr): body-frame force and grip of the last step, N (`tyres`);
        # none before the first step
        self.tyre_forces: list[tuple[float, float, float]] = []

    def command(self, cmd: KartInput) -> None:
        """Take a command, each input clamped to the model's range (steering column, rad;
        acceleration and brake, m/s^2)."""
        lo, hi = self.model.steering_limit_rad
        self.input = KartInput(min(max(cmd.steering_rad, lo), hi),
                               min(max(cmd.accel_mps2, 0.0), self.model.max_accel_mps2),
                               min(max(cmd.brake_mps2, 0.0), self.model.max_brake_mps2),
                               cmd.reverse, cmd.estop)

    def set_wheel_friction(self, mu: list[float]) -> None:
        """Per-wheel floor friction: scales each tyre's D by mu / the reference friction."""
        ref = self.model.tyre_reference_friction
        self.mu_scale = [f * self.model.tire_friction / ref for f in mu]

    def pre_step(self) -> None:
        """Turn the steering column towards its target at the steering rate, and apply the four
        tyre forces and the air drag for the coming physics step."""
        m, inp, dt, c = self.model, self.input, self.dt, self.client
        step = m.steering_rate_radps * dt
        self.column += min(max(inp.steering_rad - self.column, -step), step)
        angles = wheel_angles(m, self.column)
        if angles != self._steer_target:  # a motor keeps its target: set it when it moves
            self._steer_target = angles
            pb.setJointMotorControlArray(self.body, self.steer, pb.POSITION_CONTROL,
                                         targetPositions=angles, forces=[800.0, 800.0],
                                         positionGains=[1.0, 1.0], physicsClientId=c)
        com, quat = pb.getBasePositionAndOrientation(self.body, physicsClientId=c)
        lin, ang = pb.getBaseVelocity(self.body, physicsClientId=c)
        r = pb.getMatrixFromQuaternion(quat)  # row-major body-to-world
        vx = r[0] * lin[0] + r[3] * lin[1] + r[6] * lin[2]
        vy = r[1] * lin[0] + r[4] * lin[1] + r[7] * lin[2]
        yaw_rate = r[2] * ang[0] + r[5] * ang[1] + r[8] * ang[2]
        demand = drive_demand(m, inp.accel_mps2, inp.brake_mps2, inp.reverse, inp.estop, vx)
        steer = [0.0, 0.0, *(s[0] for s in pb.getJointStates(self.body, self.steer,
                                                             physicsClientId=c))]
        loads = normal_loads(m, self.tyres, *self.accel)
        off = self._com_offset  # the chassis' centre of mass in base_link
        dz = -m.rear_wheel_radius_m - off[2]  # the floor, from the chassis' centre of mass
        spin, fx_sum, fy_sum = [], 0.0, 0.0
        self.tyre_forces = []
        for w, load, delta, mu in zip(self.tyres, loads, steer, self.mu_scale, strict=True):
            dx, dy = w.x_m - off[0], w.y_m - off[1]
            f = wheel_force(m, w, load, demand, delta, (vx - yaw_rate * dy, vy + yaw_rate * dx),
                            mu)
            # grip: the lateral radius of the friction ellipse at this load
            self.tyre_forces.append((f.fx_n, f.fy_n, load * w.tyre.d_mps2 * mu))
            at = (com[0] + r[0] * dx + r[1] * dy + r[2] * dz,
                  com[1] + r[3] * dx + r[4] * dy + r[5] * dz,
                  com[2] + r[6] * dx + r[7] * dy + r[8] * dz)
            force = (r[0] * f.fx_n + r[1] * f.fy_n, r[3] * f.fx_n + r[4] * f.fy_n,
                     r[6] * f.fx_n + r[7] * f.fy_n)
            pb.applyExternalForce(self.body, -1, force, at, pb.WORLD_FRAME, physicsClientId=c)
            fx_sum, fy_sum = fx_sum + f.fx_n, fy_sum + f.fy_n
            spin.append(f.spin_mps / w.radius_m)
        drag = air_drag_n(m, vx)
        pb.applyExternalForce(self.body, -1, (r[0] * drag, r[3] * drag, r[6] * drag), com,
                              pb.WORLD_FRAME, physicsClientId=c)
        self.accel = ((fx_sum + drag) / m.mass_kg, fy_sum / m.mass_kg)
        pb.setJointMotorControlArray(self.body, self.wheels, pb.VELOCITY_CONTROL,
                                     targetVelocities=spin, forces=[WHEEL_SPIN_TORQUE_NM] * 4,
                                     physicsClientId=c)

    def wheel_states(self) -> tuple[list[float], list[float], list[float]]:
        """Steer-joint angles (rad), and the four wheels' angles (rad) and speeds (rad/s), in
        the order rl, rr, fl, fr."""
        js = pb.getJointStates(self.body, self.steer + self.wheels, physicsClientId=self.client)
        return [s[0] for s in js[:2]], [s[0] for s in js[2:]], [s[1] for s in js[2:]]

    def wheel_contacts_xy(self, state: BodyState) -> np.ndarray:
        """Points under the four wheel centres (rl, rr, fl, fr), from the model's geometry."""
        rel = np.column_stack([np.asarray(self.model.wheel_xy_m), np.zeros(4)])
        out: np.ndarray = (np.asarray(state.xyz) + rel @ state.rotation.T)[:, :2]
        return out
