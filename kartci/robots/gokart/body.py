"""The go-kart as a PyBullet multibody: its chassis weighed to the parameters' mass properties
(inertia.py), tyre forces from a slip model (tyres.py) applied at the wheels' contact points
every physics step, position-controlled steer joints through the measured steering map, and
wheels spun at their road speed and slip (for odometry and looks; their contacts have no
friction and only carry the weight)."""

from __future__ import annotations

from collections import deque
from pathlib import Path

import numpy as np

from kartci._bullet import pb, quiet_c_output
from kartci.robots.gokart.inertia import weigh_chassis
from kartci.robots.gokart.params import GokartModel
from kartci.robots.gokart.steering import KartInput, wheel_angles
from kartci.robots.gokart.tyres import FourTyres, drive_demand, wheels
from kartci.sim.body import Base, BodyState, Reading
from kartci.sim.urdf import fixed_frames, physics_urdf

WHEEL_SPIN_TORQUE_NM = 20.0  # spins the (frictionless) wheels at their rolling speed
_SPIN_TORQUES_NM = (WHEEL_SPIN_TORQUE_NM,) * 4


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
        # commands on their way to the actuators (model.command_delay_s): (due step, input)
        self._delay_steps = round(model.command_delay_s / dt_s)
        self._pending: deque[tuple[int, KartInput]] = deque()
        self._steps = 0  # physics steps taken
        self.column = 0.0  # steering-column angle, rad
        self._steer_column: float | None = None  # column angle of the steer motors' targets, rad
        # per wheel (rl, rr, fl, fr): body-frame force and grip of the last step, N (`tyres`);
        # none before the first step
        self.tyre_forces: list[tuple[float, float, float]] = []
        off = self._com_off  # the chassis' centre of mass in base_link
        self._four = FourTyres(model, off)
        self._arms = [(w.x_m - off[0], w.y_m - off[1]) for w in self.tyres]  # from the CoM, m
        self._floor_dz = -model.rear_wheel_radius_m - off[2]  # the floor, from the CoM, m
        # the wheel centres' points on the floor in base_link (rl, rr, fl, fr), m
        self._wheels_rel = np.column_stack([np.asarray(model.wheel_xy_m), np.zeros(4)])
        self._rd: Reading | None = None  # this step's reading of the base (see reading())
        self._st: BodyState | None = None

    def command(self, cmd: KartInput) -> None:
        """Take a command, each input clamped to the model's range (steering column, rad;
        acceleration and brake, m/s^2)."""
        m = self.model
        lo, hi = m.steering_limit_rad
        steer = cmd.steering_rad + m.steering_offset_rad if m.steering_offset_rad else (
            cmd.steering_rad)
        taken = KartInput(min(max(steer, lo), hi),
                          min(max(cmd.accel_mps2, 0.0), m.max_accel_mps2),
                          min(max(cmd.brake_mps2, 0.0), m.max_brake_mps2),
                          cmd.reverse, cmd.estop)
        if self._delay_steps:
            self._pending.append((self._steps + self._delay_steps, taken))
        else:
            self.input = taken

    def set_wheel_friction(self, mu: list[float]) -> None:
        """Per-wheel floor friction: each tyre's peak force is this mu (times the kart's
        `tire_friction`) times its load, less for a loaded tyre (tyres.py)."""
        self.mu_scale = [f * self.model.tire_friction for f in mu]

    def pre_step(self) -> None:
        """Turn the steering column towards its target at the steering rate, and apply the four
        tyre forces and the air drag for the coming physics step."""
        while self._pending and self._pending[0][0] <= self._steps:
            self.input = self._pending.popleft()[1]
        self._steps += 1
        m, inp, dt, c = self.model, self.input, self.dt, self.client
        step = m.steering_rate_radps * dt
        column = self.column = self.column + min(max(inp.steering_rad - self.column, -step),
                                                 step)
        if column != self._steer_column:  # a motor keeps its target: set it when it moves
            self._steer_column = column
            angles = wheel_angles(m, column)
            pb.setJointMotorControlArray(self.body, self.steer, pb.POSITION_CONTROL,
                                         targetPositions=angles, forces=[800.0, 800.0],
                                         positionGains=[1.0, 1.0], physicsClientId=c)
        rd = self.reading()
        r, lin, ang = rd.rotation, rd.lin, rd.ang  # r: row-major body-to-world
        vx = r[0] * lin[0] + r[3] * lin[1] + r[6] * lin[2]
        vy = r[1] * lin[0] + r[4] * lin[1] + r[7] * lin[2]
        yaw_rate = r[2] * ang[0] + r[5] * ang[1] + r[8] * ang[2]
        demand = drive_demand(m, inp.accel_mps2, inp.brake_mps2, inp.reverse, inp.estop, vx)
        fl, fr = pb.getJointStates(self.body, self.steer, physicsClientId=c)
        self.tyre_forces, spin, drag, self.accel = self._four.forces(
            demand, (fl[0], fr[0]), vx, vy, yaw_rate, self.accel, self.mu_scale)
        self._push(rd, drag)
        pb.setJointMotorControlArray(self.body, self.wheels, pb.VELOCITY_CONTROL,
                                     targetVelocities=spin, forces=_SPIN_TORQUES_NM,
                                     physicsClientId=c)
        self.forget()  # the physics step follows

    def _push(self, rd: Reading, drag_n: float) -> None:
        """The four tyre forces at their contact points and the drag at the centre of mass, as
        one force and one torque about the centre of mass: two calls into PyBullet, not five.
        Summed as Bullet sums what it is given (the force in order, each torque as (point -
        centre of mass) x force), so the body gets the same bits."""
        (c0, c1, c2), (r0, r1, r2, r3, r4, r5, r6, r7, r8) = rd.com, rd.rotation
        dz = self._floor_dz
        z0, z1, z2 = r2 * dz, r5 * dz, r8 * dz
        fx_w = fy_w = fz_w = tx = ty = tz = 0.0
        for (fx, fy, _), (dx, dy) in zip(self.tyre_forces, self._arms, strict=True):
            px = c0 + r0 * dx + r1 * dy + z0 - c0
            py = c1 + r3 * dx + r4 * dy + z1 - c1
            pz = c2 + r6 * dx + r7 * dy + z2 - c2
            f0, f1, f2 = r0 * fx + r1 * fy, r3 * fx + r4 * fy, r6 * fx + r7 * fy
            fx_w, fy_w, fz_w = fx_w + f0, fy_w + f1, fz_w + f2
            tx, ty, tz = (tx + (py * f2 - pz * f1), ty + (pz * f0 - px * f2),
                          tz + (px * f1 - py * f0))
        c = self.client
        pb.applyExternalForce(self.body, -1, (fx_w + r0 * drag_n, fy_w + r3 * drag_n,
                                              fz_w + r6 * drag_n), rd.com, pb.WORLD_FRAME,
                              physicsClientId=c)
        pb.applyExternalTorque(self.body, -1, (tx, ty, tz), pb.WORLD_FRAME, physicsClientId=c)

    def reading(self) -> Reading:
        """The base's pose and velocity, read from PyBullet once between physics steps:
        the sensors' `state()` and the next `pre_step` share it. `pre_step` drops it before the
        physics step; code that steps PyBullet without `pre_step` calls `forget()` first."""
        if self._rd is None:
            self._rd = self.read()
        return self._rd

    def state(self) -> BodyState:
        """Ground truth now (base_link), from this step's one reading."""
        if self._st is None:
            self._st = self.state_of(self.reading())
        return self._st

    def forget(self) -> None:
        """The body moves (a physics step, a placement): the next state is read anew."""
        self._rd, self._st = None, None

    def reset_pose(self, xyz: np.ndarray, quat: tuple[float, float, float, float]) -> None:
        """Place base_link at `xyz`."""
        super().reset_pose(xyz, quat)
        self.forget()

    def place(self, x_m: float, y_m: float, yaw_rad: float, v_mps: float,
              yaw_rate_radps: float) -> None:
        """Put base_link at (x, y, yaw) moving at `v_mps` and turning at `yaw_rate_radps`
        (see Base.place)."""
        super().place(x_m, y_m, yaw_rad, v_mps, yaw_rate_radps)
        self.forget()

    def wheel_states(self) -> tuple[list[float], list[float], list[float]]:
        """Steer-joint angles (rad), and the four wheels' angles (rad) and speeds (rad/s), in
        the order rl, rr, fl, fr."""
        js = pb.getJointStates(self.body, self.steer + self.wheels, physicsClientId=self.client)
        return [s[0] for s in js[:2]], [s[0] for s in js[2:]], [s[1] for s in js[2:]]

    def wheel_contacts_xy(self, state: BodyState) -> np.ndarray:
        """Points under the four wheel centres (rl, rr, fl, fr), from the model's geometry."""
        out: np.ndarray = (np.asarray(state.xyz) + self._wheels_rel @ state.rotation.T)[:, :2]
        return out
