"""The go-kart in the loop: body, IMU, lidar, camera, wheel odometry, tyre forces, collisions."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from kartci._bullet import pb
from kartci.errors import SpecError
from kartci.logs import header, msg, typestore
from kartci.metrics.outline import bounds
from kartci.robots.gokart import noise
from kartci.robots.gokart.body import Gokart
from kartci.robots.gokart.outline import outline
from kartci.robots.gokart.params import GokartModel, KartSensors
from kartci.robots.gokart.steering import (
    KartInput,
    column_for_wheel_angle,
    speed_to_pedals,
    steer_for_turn_rate,
)
from kartci.sim import lidar as lidar_mod
from kartci.sim.blocks import Block
from kartci.sim.body import BodyState
from kartci.sim.markers import COLLISION_MARKERS, collision_marker
from kartci.sim.messages import WORLD_FRAME, frozen, joint_state, tf_message, transform
from kartci.sim.reach import Reach
from kartci.sim.robot import Put, RobotContext
from kartci.sim.robots import RobotBase, every
from kartci.sim.urdf import urdf_path
from kartci.worlds.track.world import TrackWorld


@dataclass
class _Contact:
    start_ns: int
    last_ns: int
    impulse: float
    position: tuple[float, float, float]


class KartRobot(RobotBase):
    """A go-kart in the loop: its body, IMU, lidar, camera and wheel odometry, collision reports,
    and a drive-by-wire for the standard command topics."""

    STATIC = ("cog_link", "imu_link", "velodyne_link", "camera_link")
    JOINTS = ("front_left_wheel_steer_joint", "front_right_wheel_steer_joint",
              "rear_left_wheel_joint", "rear_right_wheel_joint", "front_left_wheel_joint",
              "front_right_wheel_joint")
    CONTACT_GAP_NS = 100_000_000  # contacts closer than 0.1 s apart are one collision

    def __init__(self, ctx: RobotContext) -> None:
        world, spec, dt_s, name = ctx.world, ctx.spec, ctx.dt_s, ctx.name
        if not isinstance(world, TrackWorld):
            raise SpecError(f"agent {name}: a go-kart needs a world with a track (hall, "
                            f"circuit), not {world.spec.kind}")
        self.world = world
        self.spec, self.rng, self.dt = spec, ctx.rng, dt_s
        model = spec.model
        assert isinstance(model, GokartModel)  # the robot registry chose this class by kind
        self.model = model
        sensors = spec.sensors
        assert isinstance(sensors, KartSensors)  # validated by the robot kind
        self.sensors = sensors
        self.body = Gokart(world.client, model, urdf_path(model).parent,
                           world.start_pose(spec.start), dt_s)
        super().__init__(name, ctx.agent, every(ctx.agent.period_s, dt_s), self.body.frames)
        self.client, self.odom_every, self.names, self.floor = (world.client, ctx.odom_every,
                                                                world.names, world.floor)
        world.names[self.body.body] = name
        self.imu_every = every(1.0 / sensors.imu.rate_hz, dt_s)
        self.lidar_every = every(1.0 / sensors.lidar.rate_hz, dt_s)
        self.camera_every = every(1.0 / sensors.camera.rate_hz, dt_s)
        # every step a sensor is due on is a multiple of this: the other steps return at once
        self._due_every = math.gcd(ctx.odom_every, *(
            n for n, on in ((self.imu_every, sensors.imu.enabled),
                            (self.lidar_every, sensors.lidar.enabled),
                            (self.camera_every, sensors.camera.enabled)) if on))
        self.lidar = lidar_mod.MODELS[sensors.lidar.model]
        self.azimuths = self.lidar.azimuths(sensors.lidar.rate_hz)
        self.blocks = world.blocks
        self._imu_prev: tuple[float, ...] | None = None  # the IMU point's last velocity, m/s
        rel, rel_rot = self.frames["imu_link"]
        self._imu_mount = (_t3(rel), rel_rot.tolist())  # position (m) and rotation in base_link
        self._imu_frame = f"{name}/imu_link"
        types = typestore().types
        self._imu_types = (types["sensor_msgs/msg/Imu"], types["geometry_msgs/msg/Vector3"],
                           types["geometry_msgs/msg/Quaternion"])
        acc_std, gyro_std = _imu_noise(model, sensors)
        self._imu_std = acc_std, gyro_std
        self._imu_cov = (frozen(np.diag([acc_std**2] * 3).ravel()),
                         frozen(np.diag([gyro_std**2] * 3).ravel()))
        self._bias = noise.ImuBias(sensors.imu, ctx.rng, self.imu_every * dt_s)
        self._slip = noise.WheelSlip(sensors.wheels, ctx.rng, ctx.odom_every * dt_s, 4)
        self._scans = 0
        self.contacts: dict[str, _Contact] = {}
        self.collisions_marked = 0
        self._target: tuple[float, float] | None = None  # drive-by-wire: speed, column angle
        self.bounds = bounds(outline(model))  # centre ahead, left, length, width, m
        self.reach = Reach(world.client, self.body.body, world.floor, dt_s)
        self._moving_frames = _moving_frames(name, model)
        # how far a wheel's floor point is from base_link, plus a centimetre for rounding, m
        self._wheel_reach_m = max(math.hypot(x, y) for x, y in model.wheel_xy_m) + 0.01

    def static_transforms(self) -> list[Any]:
        """tf of the CoG, IMU, lidar and camera mounts."""
        return self.static_tf(self.STATIC)

    def footprint(self) -> Block:
        """The kart as a box at its current pose, for other karts' lidar: its outline's
        bounding box."""
        st = self.body.state()
        ahead, left, length, width = self.bounds
        c, s = math.cos(st.yaw), math.sin(st.yaw)
        centre = (st.xyz[0] + ahead * c - left * s, st.xyz[1] + ahead * s + left * c)
        return Block(self.name, centre, (length, width, 0.45), st.yaw)

    def sense(self, k: int, t_ns: int, put: Put) -> None:
        """At the odometry rate: odometry, joint states, tf of the moving frames, floor friction and
        the speed loop; camera, IMU and lidar at their own rates."""
        if k % self._due_every:
            return
        odom = k % self.odom_every == 0
        camera = self.sensors.camera.enabled and k % self.camera_every == 0
        imu = self.sensors.imu.enabled and k % self.imu_every == 0
        lidar = self.sensors.lidar.enabled and k % self.lidar_every == 0
        if not (odom or camera or imu or lidar):
            return  # most physics steps publish nothing: no state read
        st = self.body.state()
        ns = self.name
        if odom:
            self.publish_pose(st, t_ns, put)
            steer, spin, speeds = self.body.wheel_states()
            put("joint_states", joint_state(
                t_ns, f"{ns}/base_link", [*self.JOINTS, "steering_column"],
                [*steer, *spin, self.body.column],
                [0.0, 0.0, *self._slip.apply(list(speeds)), 0.0]), t_ns)
            self._tyres(t_ns, put)
            self._zone_friction(st)
            self._pedals(st)
            put("/tf", tf_message(self._joint_tf(t_ns, steer, spin)), t_ns)
        if camera:
            self._camera(st, t_ns, put)
        if imu:
            self._imu(st, t_ns, put)
        if lidar:
            self._lidar(st, t_ns, put)

    def _tyres(self, t_ns: int, put: Put) -> None:
        """`tyres`: each tyre's force and grip in the last physics step (what the tyre
        saturation metric reads); nothing before the first step."""
        if not self.body.tyre_forces:
            return
        fx, fy, grip = (np.array(v, dtype=float) for v in zip(*self.body.tyre_forces,
                                                               strict=True))
        put("tyres", typestore().types["kartci_msgs/msg/TyreForces"](
            header(t_ns, f"{self.name}/base_link"), list(self.JOINTS[2:]), fx, fy, grip), t_ns)

    def _joint_tf(self, t_ns: int, steer: list[float], spin: list[float]) -> list[Any]:
        """tf of the moving frames: steer links (about z) and wheel links (about y)."""
        cos, sin, out = math.cos, math.sin, []
        for i, ((parent, child, xyz), angle) in enumerate(
                zip(self._moving_frames, (*steer, *spin), strict=True)):
            c, s = cos(angle / 2), sin(angle / 2)
            out.append(transform(t_ns, parent, child, xyz,
                                 (0.0, 0.0, s, c) if i < 2 else (0.0, s, 0.0, c)))
        return out

    def _camera(self, st: BodyState, t_ns: int, put: Put) -> None:
        """A low-resolution RGB image from camera_link (optical frame: z forward, y down)."""
        cam = self.sensors.camera
        pos, rot = self.body.frame_pose("camera_link", st)
        view = pb.computeViewMatrix(pos.tolist(), (pos + rot[:, 2]).tolist(),
                                    (-rot[:, 1]).tolist())
        proj = pb.computeProjectionMatrixFOV(math.degrees(cam.fov_rad) * cam.height_px
                                             / cam.width_px, cam.width_px / cam.height_px,
                                             0.05, 60.0)
        img = pb.getCameraImage(cam.width_px, cam.height_px, view, proj,
                                renderer=pb.ER_TINY_RENDERER, flags=pb.ER_NO_SEGMENTATION_MASK,
                                physicsClientId=self.client)
        rgb = np.asarray(img[2], dtype=np.uint8).reshape(cam.height_px, cam.width_px, 4)[..., :3]
        put("camera/image_raw", msg("sensor_msgs/msg/Image",
                                    header=header(t_ns, f"{self.name}/camera_link"),
                                    height=cam.height_px, width=cam.width_px, encoding="rgb8",
                                    is_bigendian=0, step=3 * cam.width_px,
                                    data=np.ascontiguousarray(rgb).ravel()), t_ns)

    def _imu(self, st: BodyState, t_ns: int, put: Put) -> None:
        """Specific force (gravity included) and angular rate in imu_link, from the finite
        difference of the IMU point's velocity over one IMU period. Scalar arithmetic on the
        odometry's state (numpy's 3x3 products summed in the same order: the same bits)."""
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = st.rows  # row-major body-to-world
        (x0, x1, x2), m = self._imu_mount
        wb0, wb1, wb2 = st.w_body
        vb0, vb1, vb2 = st.v_body
        w0 = r0 * wb0 + r1 * wb1 + r2 * wb2  # angular rate in the world
        w1 = r3 * wb0 + r4 * wb1 + r5 * wb2
        w2 = r6 * wb0 + r7 * wb1 + r8 * wb2
        p0 = r0 * x0 + r1 * x1 + r2 * x2  # the IMU's lever arm in the world
        p1 = r3 * x0 + r4 * x1 + r5 * x2
        p2 = r6 * x0 + r7 * x1 + r8 * x2
        v = (r0 * vb0 + r1 * vb1 + r2 * vb2 + (w1 * p2 - w2 * p1),
             r3 * vb0 + r4 * vb1 + r5 * vb2 + (w2 * p0 - w0 * p2),
             r6 * vb0 + r7 * vb1 + r8 * vb2 + (w0 * p1 - w1 * p0))
        prev, self._imu_prev = self._imu_prev, v
        period = self.imu_every * self.dt
        a0 = a1 = a2 = 0.0
        if prev is not None:
            a0, a1, a2 = ((v[0] - prev[0]) / period, (v[1] - prev[1]) / period,
                          (v[2] - prev[2]) / period)
        a0, a1, a2 = a0 + 0.0, a1 + 0.0, a2 + 9.81  # plus gravity
        acc_std, gyro_std = self._imu_std
        n = self.rng.standard_normal(6).tolist()  # white noise: the same draws as two of three
        ab, gb = ((b.tolist() for b in self._bias.sample()) if self._bias.active
                  else (_ZERO3, _ZERO3))
        # both vectors in imu_link, plus noise and bias: column j of imu_link's rotation in the
        # world is (c0, c1, c2); numpy's element-wise sums of before, in floats (the same bits)
        f, g = [], []
        for j, (m0, m1, m2) in enumerate(zip(*m, strict=True)):  # m's columns
            c0, c1, c2 = r0 * m0 + r1 * m1 + r2 * m2, r3 * m0 + r4 * m1 + r5 * m2, (
                r6 * m0 + r7 * m1 + r8 * m2)
            f.append((c0 * a0 + c1 * a1 + c2 * a2 + acc_std * n[j]) + ab[j])
            g.append((c0 * w0 + c1 * w1 + c2 * w2 + gyro_std * n[3 + j]) + gb[j])
        cov_a, cov_g = self._imu_cov
        imu, vector3, quaternion = self._imu_types
        put("imu", imu(header(t_ns, self._imu_frame), quaternion(0.0, 0.0, 0.0, 1.0),
                       NO_ORIENTATION, vector3(g[0], g[1], g[2]), cov_g,
                       vector3(f[0], f[1], f[2]), cov_a), t_ns)

    def _lidar(self, st: BodyState, t_ns: int, put: Put) -> None:
        pos, _ = self.body.frame_pose("velodyne_link", st)
        yaw = st.yaw
        extra = [o.footprint() for o in self.world.robots
                 if o is not self and isinstance(o, KartRobot)]
        spec, blocks = self.sensors.lidar, self.blocks + extra

        def scan(azimuths: np.ndarray, xyz: np.ndarray, heading: float | np.ndarray,
                 ) -> np.ndarray:
            return lidar_mod.scan_fast(self.lidar, azimuths, xyz, heading, blocks,
                                       self.world.ceiling_m, spec.range_m)

        ranges = (noise.distorted_scan(scan, self.azimuths, st, pos, spec.rate_hz)
                  if spec.motion_distortion else scan(self.azimuths, pos, yaw))
        std = spec.range_noise_std_m
        std = self.lidar.range_accuracy_m if std is None else std
        ranges = ranges + std * self.rng.standard_normal(ranges.shape)
        ranges = noise.dropout(ranges, spec, self.rng)
        self._scans += 1
        record = (self._scans - 1) % spec.record_every == 0
        pts = lidar_mod.to_points(self.lidar, self.azimuths, ranges)
        fields = [msg("sensor_msgs/msg/PointField", name=n, offset=o, datatype=d, count=1)
                  for n, o, d in (("x", 0, 7), ("y", 4, 7), ("z", 8, 7), ("intensity", 12, 7),
                                  ("ring", 16, 4))]
        put("velodyne_points", msg(
            "sensor_msgs/msg/PointCloud2", header=header(t_ns, f"{self.name}/velodyne_link"),
            height=1, width=len(pts), fields=fields, is_bigendian=False,
            point_step=pts.dtype.itemsize, row_step=pts.dtype.itemsize * len(pts),
            data=np.frombuffer(pts.tobytes(), dtype=np.uint8), is_dense=True), t_ns, record)

    def _zone_friction(self, st: BodyState) -> None:
        """Each wheel's floor friction: the floor's where no zone is within a wheel's reach of
        base_link (most ticks; no need to find where the wheels are), else the zone under it."""
        x, y, _ = st.xyz
        e = self._wheel_reach_m
        if not any(z.min_m[0] - e <= x <= z.max_m[0] + e and z.min_m[1] - e <= y <= z.max_m[1] + e
                   for z in self.world.spec.zones):
            self.body.set_wheel_friction([self.world.spec.floor_friction] * 4)
            return
        self.body.set_wheel_friction([self.world.friction_at(float(x), float(y))
                                      for x, y in self.body.wheel_contacts_xy(st)])

    def post_step(self, t_ns: int, put: Put) -> None:
        """Contacts with anything but the floor, grouped into collisions (episodes)."""
        # the reading is the one the sensors and the next step's tyres use: no extra cost
        if self.reach.clear(self.body.reading()):
            if self.contacts:  # nothing touches: collisions still open may end
                self._touched(t_ns, (), put)
            return
        self._touched(t_ns, pb.getContactPoints(bodyA=self.body.body,
                                                physicsClientId=self.client), put)

    def _touched(self, t_ns: int, near: Any, put: Put) -> None:
        """Contact points found after a step: each collision they continue or start, and the
        collisions no longer touched for CONTACT_GAP_NS reported."""
        seen: set[str] = set()
        for c in near:
            if c[2] == self.floor or c[2] == self.body.body:
                continue
            other = self.names.get(c[2], f"body_{c[2]}")
            seen.add(other)
            cur = self.contacts.get(other)
            impulse = c[9] * self.dt
            if cur is None:
                self.contacts[other] = _Contact(t_ns, t_ns, impulse, tuple(c[5]))
            else:
                cur.last_ns, cur.impulse = t_ns, cur.impulse + impulse
        for other in [o for o in self.contacts if o not in seen]:
            if t_ns - self.contacts[other].last_ns > self.CONTACT_GAP_NS:
                self._report(other, put)

    def finish(self, put: Put) -> None:
        """Report the collisions still open at the end of the run."""
        for other in list(self.contacts):
            self._report(other, put)

    def _report(self, other: str, put: Put) -> None:
        c = self.contacts.pop(other)
        put("collision", msg("kartci_msgs/msg/Collision", header=header(c.start_ns, WORLD_FRAME),
                             other=other, impulse_ns=c.impulse,
                             duration_s=(c.last_ns - c.start_ns) * 1e-9,
                             position=msg("geometry_msgs/msg/Point", x=c.position[0],
                                          y=c.position[1], z=c.position[2])), c.start_ns)
        put(COLLISION_MARKERS, collision_marker(self.collisions_marked, c.start_ns, other,
                                                c.position), c.start_ns)
        self.collisions_marked += 1

    def apply(self, topic: str, m: Any) -> None:
        """Commands the kart understands: `cmd` (kartci_msgs/KartCommand, the source document's
        format), `ackermann_cmd` (ackermann_msgs/AckermannDriveStamped) and `cmd_vel`
        (geometry_msgs/Twist or TwistStamped). The standard ones go through a drive-by-wire:
        the steering map for the wheel angle, a speed loop for the pedals."""
        if topic == "cmd":
            self._target = None
            self.body.command(KartInput(m.steering_wheel_angle_rad, m.acceleration_mps2,
                                        m.brake_mps2, m.reverse, m.emergency_stop))
        elif topic == "ackermann_cmd":
            self._drive(float(m.drive.speed), float(m.drive.steering_angle))
        elif topic == "cmd_vel":
            tw = m.twist if hasattr(m, "twist") else m
            v = float(tw.linear.x)
            self._drive(v, steer_for_turn_rate(self.model, v, float(tw.angular.z)))

    def _drive(self, v_mps: float, wheel_angle_rad: float) -> None:
        self._target = (v_mps, column_for_wheel_angle(self.model, wheel_angle_rad))
        self._pedals(self.body.state())

    def _pedals(self, st: BodyState) -> None:
        """Re-evaluate the speed loop on the measured speed (at every odometry tick)."""
        if self._target is not None:
            v_cmd, column = self._target
            accel, brake, reverse = speed_to_pedals(v_cmd, st.v_body[0],
                                                    self.model.speed_gain_per_s)
            self.body.command(KartInput(column, accel, brake, reverse))

    def pre_step(self, k: int) -> None:
        """Steering and wheel motors, from the latest command."""
        self.body.pre_step()

    def done(self, k: int) -> bool:
        """Never: a kart drives until the scenario's duration is up."""
        return False

    def reinitialise(self, x_m: float, y_m: float, yaw_rad: float, v_mps: float,
                     yaw_rate_radps: float) -> None:
        """Continue from a recorded state (kartci simreal's windows): pose and motion of the
        body, wheels rolling at that speed (on their collision radius); the steering column
        keeps its angle and the next command sets the rest."""
        m, body = self.model, self.body
        body.place(x_m, y_m, yaw_rad, v_mps, yaw_rate_radps)
        half = abs(m.wheel_xy_m[0][1])
        defaults = (m.rear_wheel_radius_m,) * 2 + (m.front_wheel_radius_m,) * 2
        radii = [body.rolling_radius(j, d) for j, d in zip(body.wheels, defaults, strict=True)]
        spin = [(v_mps - yaw_rate_radps * half) / radii[0],
                (v_mps + yaw_rate_radps * half) / radii[1], v_mps / radii[2], v_mps / radii[3]]
        body.spin(body.wheels, spin)
        body.accel = (0.0, 0.0)  # no load transfer carried over from before the jump
        self._target, self._imu_prev = None, None
        self.contacts.clear()


Frame = tuple[str, str, tuple[float, float, float]]  # parent, child, offset (m)


def _moving_frames(ns: str, model: GokartModel) -> list[Frame]:
    """Parent, child and offset (m) of the moving frames: the two steer links (turning about
    z), then the wheel links rl, rr, fl, fr (spinning about y). Named once, not every tick."""
    (x_r, y_r), (x_f, y_f) = model.wheel_xy_m[0], model.wheel_xy_m[2]
    out = [(f"{ns}/base_link", f"{ns}/front_{side}_wheel_steer_link", (x_f, sign * y_f, -0.015))
           for side, sign in (("left", 1), ("right", -1))]
    out += [(f"{ns}/{parent}", f"{ns}/{name}_wheel_link", xyz) for name, parent, xyz in (
        ("rear_left", "base_link", (x_r, y_r, 0.0)),
        ("rear_right", "base_link", (x_r, -y_r, 0.0)),
        ("front_left", "front_left_wheel_steer_link", (0.0, 0.0, 0.0)),
        ("front_right", "front_right_wheel_steer_link", (0.0, 0.0, 0.0)))]
    return out


def _t3(v: np.ndarray) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


_ZERO3 = (0.0, 0.0, 0.0)  # no IMU bias
NO_ORIENTATION = frozen(np.array([-1.0] + [0.0] * 8))  # REP 145: no orientation estimate

# Table 3.6, read as 1-sigma white noise: accuracy x default full scale.
IMU_NOISE = {"bumblebee": (0.01 * 8 * 9.81, 0.015 * math.radians(245)),  # IRIMU-V2
             "herbie": (0.0002 * 8 * 9.81, 0.0002 * math.radians(300))}  # 3DM-GX5-AHRS


def _imu_noise(model: GokartModel, sensors: KartSensors) -> tuple[float, float]:
    acc, gyro = IMU_NOISE[model.variant]
    if sensors.imu.accel_noise_std_mps2 is not None:
        acc = sensors.imu.accel_noise_std_mps2
    if sensors.imu.gyro_noise_std_radps is not None:
        gyro = sensors.imu.gyro_noise_std_radps
    return acc, gyro
