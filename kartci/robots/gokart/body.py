"""The go-kart as a PyBullet multibody: velocity-controlled rear wheels with a torque limit,
position-controlled steer joints through the measured steering map, free front wheels."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kartci._bullet import pb, quiet_c_output
from kartci.robots.gokart.params import GokartModel
from kartci.sim.body import Base, BodyState
from kartci.sim.urdf import fixed_frames, physics_urdf
from kartci.vehicle import KartInput, wheel_angles

ROLLING_DECEL_MPS2 = 0.15  # coasting: rolling resistance and drivetrain drag
AIR_DRAG_PER_M = 0.004  # aerodynamic deceleration = this * v^2
SLIP_WINDOW_MPS = 0.5  # the motor's speed reference stays within this of the wheel speed


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
        pb.setJointMotorControlArray(self.body, self.front, pb.VELOCITY_CONTROL,
                                     forces=[0.0, 0.0], physicsClientId=client)
        self.friction = [-1.0] * 4
        self.input = KartInput()
        self.column = 0.0  # steering-column angle, rad
        self.v_ref = 0.0  # motor speed reference at the rear tire, m/s

    def command(self, cmd: KartInput) -> None:
        """Take a command, each input clamped to the model's range (steering column, rad;
        acceleration and brake, m/s^2)."""
        lo, hi = self.model.steering_limit_rad
        self.input = KartInput(min(max(cmd.steering_rad, lo), hi),
                               min(max(cmd.accel_mps2, 0.0), self.model.max_accel_mps2),
                               min(max(cmd.brake_mps2, 0.0), self.model.max_brake_mps2),
                               cmd.reverse, cmd.estop)

    def set_wheel_friction(self, mu: list[float]) -> None:
        """Per-wheel floor friction (Bullet multiplies the two bodies' coefficients)."""
        for link, f, old in zip(self.wheels, mu, self.friction, strict=True):
            if f != old:
                pb.changeDynamics(self.body, link, lateralFriction=f * self.model.tire_friction,
                                  physicsClientId=self.client)
        self.friction = list(mu)

    def pre_step(self) -> None:
        """Turn the steering column towards its target at the steering rate, and drive the rear
        wheels at the motor's speed reference within the torque limit."""
        m, inp, dt = self.model, self.input, self.dt
        step = m.steering_rate_radps * dt
        self.column += min(max(inp.steering_rad - self.column, -step), step)
        left, right = wheel_angles(m, self.column)
        pb.setJointMotorControlArray(self.body, self.steer, pb.POSITION_CONTROL,
                                     targetPositions=[left, right], forces=[800.0, 800.0],
                                     positionGains=[1.0, 1.0], physicsClientId=self.client)
        v = self.rear_speed()
        ref = self.v_ref
        if inp.estop:
            ref = 0.0
        else:
            direction = -1.0 if inp.reverse else 1.0
            decel = inp.brake_mps2 + ROLLING_DECEL_MPS2 + AIR_DRAG_PER_M * ref * ref
            ref += direction * inp.accel_mps2 * dt
            ref = max(ref - decel * dt, 0.0) if ref > 0 else min(ref + decel * dt, 0.0)
            ref = min(max(ref, -m.reverse_speed_mps), m.max_speed_mps)
            ref = min(max(ref, v - SLIP_WINDOW_MPS), v + SLIP_WINDOW_MPS)
        self.v_ref = ref
        # two rear motors (REFERENCE.md): each wheel's speed follows its own path radius, an
        # electronic differential on the measured yaw rate, so the axle does not scrub
        yaw_rate = float(pb.getBaseVelocity(self.body, physicsClientId=self.client)[1][2])
        half = abs(m.wheel_xy_m[0][1])
        w_left = (ref - yaw_rate * half) / m.rear_wheel_radius_m
        w_right = (ref + yaw_rate * half) / m.rear_wheel_radius_m
        tau = m.wheel_torque_limit_nm * (3.0 if inp.estop else 1.0)
        pb.setJointMotorControlArray(self.body, self.rear, pb.VELOCITY_CONTROL,
                                     targetVelocities=[w_left, w_right], forces=[tau, tau],
                                     physicsClientId=self.client)

    def rear_speed(self) -> float:
        """Mean rear-wheel speed at the tire, m/s."""
        js = pb.getJointStates(self.body, self.rear, physicsClientId=self.client)
        return float(js[0][1] + js[1][1]) / 2 * self.model.rear_wheel_radius_m

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
