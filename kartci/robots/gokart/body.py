"""The go-kart as a PyBullet multibody: tyre forces from a slip model (tyres.py) applied to the
chassis every physics step, position-controlled steer joints through the measured steering map,
and wheels spun at their rolling speed (for odometry and looks; their contacts have no
friction and only carry the weight)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from kartci._bullet import pb, quiet_c_output
from kartci.robots.gokart.params import GokartModel
from kartci.robots.gokart.steering import KartInput, wheel_angles
from kartci.robots.gokart.tyres import air_drag_n, drive_demand, wheel_force, wheels
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
                str(physics_urdf(model_dir / model.urdf)),
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
        self.radii = [model.rear_wheel_radius_m] * 2 + [model.front_wheel_radius_m] * 2
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
        dz = -m.cog_height_m
        spin = []
        self.tyre_forces = []
        for w, delta, mu, radius in zip(self.tyres, steer, self.mu_scale, self.radii,
                                        strict=True):
            fx, fy = wheel_force(m, w, demand, delta, (vx, vy), yaw_rate, mu)
            # grip: the radius of wheel_force's friction circle
            self.tyre_forces.append((fx, fy, w.load_kg * w.tyre.d_mps2 * mu))
            at = (com[0] + r[0] * w.dx_m + r[1] * w.dy_m + r[2] * dz,
                  com[1] + r[3] * w.dx_m + r[4] * w.dy_m + r[5] * dz,
                  com[2] + r[6] * w.dx_m + r[7] * w.dy_m + r[8] * dz)
            force = (r[0] * fx + r[1] * fy, r[3] * fx + r[4] * fy, r[6] * fx + r[7] * fy)
            pb.applyExternalForce(self.body, -1, force, at, pb.WORLD_FRAME, physicsClientId=c)
            v_wheel = vx - yaw_rate * w.dy_m
            v_lat = vy + yaw_rate * w.dx_m
            spin.append((math.cos(delta) * v_wheel + math.sin(delta) * v_lat) / radius)
        drag = air_drag_n(m, vx)
        pb.applyExternalForce(self.body, -1, (r[0] * drag, r[3] * drag, r[6] * drag), com,
                              pb.WORLD_FRAME, physicsClientId=c)
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
