"""The `localization` node: lidar scans registered against the world's map, fused with wheel
odometry and the gyroscope in a planar EKF. Reads `velodyne_points`, `imu`, `joint_states`
and the track (for the initial guess's place); publishes `localization/odom`
(nav_msgs/Odometry with covariance), tf `map -> <ns>/localization/odom -> <ns>/localization/
base_link` and every `cloud_every`-th deskewed scan on `localization/cloud`.

The estimate's frames carry a `localization/` prefix: the simulator already publishes the true
`map -> <ns>/base_link`, and one frame cannot have two parents in a tf tree."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from kartci.core import ROBOTS, AgentContext, Outbox
from kartci.errors import SpecError
from kartci.localization.deskew import deskew
from kartci.localization.ekf import BIAS, VY, Noise, PlanarEkf, wrap
from kartci.localization.params import LocalizationParams
from kartci.localization.registration import MapMatcher, Match, pose_matrix
from kartci.logs.types import WORLD_FRAME, header, msg, stamp_ns
from kartci.pointcloud import cloud_xyz
from kartci.project import BUILTIN_SIMS
from kartci.worlds.track import TRACK_TOPIC, track_from_text

SCAN_RATE_HZ = 10.0  # the revolution time deskewing assumes when the header gives none


def map_path(name: str, ctx: AgentContext) -> Path:
    """A map named relative to the world folders of the project the agent runs in
    (`AgentContext.project`; kartci's own for a scenario built by hand), or an absolute path.
    A loaded scenario's maps are absolute already: found and checked where it was loaded."""
    if Path(name).is_absolute():
        return Path(name)
    folders = ctx.project.world_path if ctx.project is not None else (BUILTIN_SIMS,)
    for folder in folders:
        if (folder / name).is_file():
            return folder / name
    raise SpecError(f"map {name[:120]!r} not found (searched {', '.join(map(str, folders))})")


class LocalizationNode:
    """One robot's localization (see the module's docstring); its kind names the wheels whose
    joint states give the forward speed (`RobotKind.odometry`)."""

    def __init__(self, spec: LocalizationParams, ctx: AgentContext) -> None:
        """Load and preprocess the map; the filter starts when the track arrives."""
        odometry = ROBOTS.get(ctx.model.kind).odometry
        assert odometry is not None  # Node.build checked that the robot's kind fits
        self.spec, self.ns, self.period_s = spec, ctx.name, spec.period_s
        wheels = odometry(ctx.model)
        self.wheels, self.wheel_radius_m = wheels.joints, wheels.radius_m
        self.inputs: tuple[str, ...] = (TRACK_TOPIC, "/tf_static", "imu", "joint_states",
                                        "velodyne_points")
        self.mount = np.array([0.0, 0.0, spec.sensor_height_m])  # velodyne_link in base_link
        self.imu_xy = np.zeros(2)  # imu_link in base_link, from /tf_static (lever arm)
        self.z_m = 0.0  # base_link's height, from registration
        self.matcher = MapMatcher.from_file(map_path(spec.map, ctx), spec.map_voxel_m, spec.method,
                                            spec.max_correspondence_m, spec.max_iterations,
                                            spec.vgicp_voxel_m)
        self.ekf: PlanarEkf | None = None
        self.dead_reckoning = np.zeros(3)  # odom -> base_link: wheels, gyro, filtered vy
        self.v_mps = self.w_radps = 0.0
        self.w_prev: float | None = None  # the last corrected yaw rate: yaw acceleration
        self.t_imu_ns: int | None = None
        self.scan: tuple[int, np.ndarray] | None = None
        self.scans = 0
        self.outliers: list[np.ndarray] = []

    def on_message(self, topic: str, message: Any) -> None:
        """Track: start the filter at the guess; joint states: wheel speed; IMU: predict;
        scan: keep it for the next step."""
        if topic == TRACK_TOPIC and self.ekf is None:
            self._start(track_from_text(message.data, TRACK_TOPIC))
        elif topic == "/tf_static":
            for tf in message.transforms:
                t = tf.transform.translation
                if tf.child_frame_id == f"{self.ns}/velodyne_link":
                    self.mount = np.array([t.x, t.y, t.z])
                elif tf.child_frame_id == f"{self.ns}/imu_link":
                    self.imu_xy = np.array([t.x, t.y])
        elif topic == "joint_states":
            names = list(message.name)
            if all(n in names for n in self.wheels):
                self.v_mps = self.wheel_radius_m * float(np.mean(
                    [message.velocity[names.index(n)] for n in self.wheels]))
        elif topic == "imu":
            self._predict(stamp_ns(message.header), float(message.angular_velocity.z),
                          float(message.linear_acceleration.y))
        elif topic == "velodyne_points":
            self.scan = (stamp_ns(message.header), cloud_xyz(message))

    def _start(self, track: Any) -> None:
        g = self.spec.initial
        x, y, yaw = track.pose_at(g.along_m)
        s = self.spec
        self.ekf = PlanarEkf(x + g.error_xy_m[0], y + g.error_xy_m[1], yaw + g.error_yaw_rad,
                             g.std_xy_m, g.std_yaw_rad,
                             Noise(s.wheel_speed_std_mps, s.gyro_std_radps,
                                   s.gyro_bias_walk_radps_per_sqrt_s, s.accel_std_mps2))

    def _predict(self, t_ns: int, gyro_radps: float, accel_y_mps2: float) -> None:
        """One IMU sample: the lateral acceleration moved from imu_link to base_link
        (a_base = a_imu - yaw accel x lever - centripetal), then the filter's prediction."""
        if self.ekf is None:
            return
        dt = 0.0 if self.t_imu_ns is None else (t_ns - self.t_imu_ns) * 1e-9
        self.t_imu_ns = t_ns
        w = gyro_radps - float(self.ekf.s[BIAS])
        alpha = 0.0 if self.w_prev is None or dt <= 0 else (w - self.w_prev) / dt
        self.w_prev = w
        rx, ry = self.imu_xy
        lat_accel = accel_y_mps2 - alpha * rx + w * w * ry
        self.ekf.predict(self.v_mps, gyro_radps, dt, lat_accel)
        self.w_radps = gyro_radps - float(self.ekf.s[BIAS])
        vy = float(self.ekf.s[VY])
        x, y, yaw = self.dead_reckoning
        c, s = math.cos(yaw), math.sin(yaw)
        self.dead_reckoning = np.array([x + (self.v_mps * c - vy * s) * dt,
                                        y + (self.v_mps * s + vy * c) * dt,
                                        wrap(yaw + self.w_radps * dt)])

    def step(self, t_ns: int) -> Outbox:
        """Register a waiting scan, then publish the estimate and its tf."""
        if self.ekf is None:
            return []
        out: Outbox = []
        if self.scan is not None:
            out += self._register(*self.scan)
            self.scan = None
        return [*out, ("localization/odom", self._odometry(t_ns)), ("/tf", self._tf(t_ns))]

    def _register(self, t_ns: int, xyz: np.ndarray) -> Outbox:
        assert self.ekf is not None
        s = self.spec
        far = np.einsum("ij,ij->i", xyz[:, :2], xyz[:, :2]) >= s.min_range_m**2
        xyz = xyz[far & np.isfinite(xyz).all(axis=1)]
        if s.deskew:
            mx, my, _ = self.mount  # the sensor's own velocity: base_link's + w x mount
            xyz = deskew(xyz, self.v_mps - self.w_radps * my, self.w_radps, SCAN_RATE_HZ,
                         float(self.ekf.s[VY]) + self.w_radps * mx)
        self.scans += 1
        out: Outbox = []
        if (self.scans - 1) % s.cloud_every == 0:
            out.append(("localization/cloud", _cloud(t_ns, f"{self.ns}/velodyne_link", xyz)))
        if s.registration:
            x, y, yaw = self.ekf.s[:3]
            c, sn = math.cos(yaw), math.sin(yaw)
            mx, my, mz = self.mount
            guess = pose_matrix(x + c * mx - sn * my, y + sn * mx + c * my, self.z_m + mz, yaw)
            self._fuse(self.matcher.align(xyz, s.scan_voxel_m, guess))
        return out

    def _fuse(self, match: Match) -> None:
        """Use a good registration; several consistent ones the gate refused mean the filter
        is lost (kidnapped): jump onto them."""
        assert self.ekf is not None
        s = self.spec
        if not match.converged or match.inlier_ratio < s.min_inlier_ratio:
            return
        sx, sy, yaw = match.xy_yaw  # the sensor's pose -> base_link's
        c, sn = math.cos(yaw), math.sin(yaw)
        mx, my, _ = self.mount
        z = np.array([sx - (c * mx - sn * my), sy - (sn * mx + c * my), yaw])
        self.z_m = float(match.T_map_sensor[2, 3] - self.mount[2])
        R = np.diag([s.registration_std_m**2, s.registration_std_m**2,
                     s.registration_std_rad**2])
        if self.ekf.mahalanobis2(z, R) <= s.gate_chi2:
            self.ekf.update(z, R)
            self.outliers = []
            return
        offset = z - self.ekf.s[:3]
        offset[2] = wrap(float(offset[2]))
        if self.outliers and np.linalg.norm(offset[:2] - self.outliers[-1][:2]) > 0.3:
            self.outliers = []
        self.outliers.append(offset)
        if len(self.outliers) >= s.relocalize_after:
            self.ekf.reset(z, 4 * R)
            self.outliers = []

    def _odometry(self, t_ns: int) -> Any:
        assert self.ekf is not None
        x, y, yaw, vy = self.ekf.s[:4]
        P = self.ekf.P
        pose_cov = np.zeros((6, 6))
        pose_cov[np.ix_([0, 1, 5], [0, 1, 5])] = P[:3, :3]
        pose_cov[2, 2] = pose_cov[3, 3] = pose_cov[4, 4] = 1e-4  # flat floor: z, roll, pitch
        twist_cov = np.zeros((6, 6))
        twist_cov[0, 0] = (self.spec.wheel_speed_std_mps + 0.05 * abs(self.v_mps)) ** 2
        twist_cov[1, 1] = P[VY, VY]
        twist_cov[5, 5] = self.spec.gyro_std_radps**2 + P[BIAS, BIAS]
        return msg("nav_msgs/msg/Odometry", header=header(t_ns, WORLD_FRAME),
                   child_frame_id=f"{self.ns}/localization/base_link",
                   pose=msg("geometry_msgs/msg/PoseWithCovariance",
                            pose=_pose(x, y, self.z_m, yaw), covariance=pose_cov.ravel()),
                   twist=msg("geometry_msgs/msg/TwistWithCovariance",
                             twist=msg("geometry_msgs/msg/Twist",
                                       linear=_vec(self.v_mps, vy, 0.0),
                                       angular=_vec(0.0, 0.0, self.w_radps)),
                             covariance=twist_cov.ravel()))

    def _tf(self, t_ns: int) -> Any:
        """map -> odom (the registration's correction), odom -> base_link (dead reckoning)."""
        assert self.ekf is not None
        x, y, yaw = self.ekf.s[:3]
        ox, oy, oyaw = self.dead_reckoning
        c_yaw = wrap(yaw - oyaw)  # map <- odom = map <- base * (odom <- base)^-1
        c, s = math.cos(c_yaw), math.sin(c_yaw)
        tx, ty = x - (c * ox - s * oy), y - (s * ox + c * oy)
        odom, base = f"{self.ns}/localization/odom", f"{self.ns}/localization/base_link"
        return msg("tf2_msgs/msg/TFMessage", transforms=[
            _transform(t_ns, WORLD_FRAME, odom, tx, ty, c_yaw),
            _transform(t_ns, odom, base, ox, oy, oyaw)])


def _vec(x: float, y: float, z: float) -> Any:
    return msg("geometry_msgs/msg/Vector3", x=float(x), y=float(y), z=float(z))


def _quat(yaw: float) -> Any:
    return msg("geometry_msgs/msg/Quaternion", x=0.0, y=0.0, z=math.sin(yaw / 2),
               w=math.cos(yaw / 2))


def _pose(x: float, y: float, z: float, yaw: float) -> Any:
    return msg("geometry_msgs/msg/Pose", position=msg("geometry_msgs/msg/Point", x=float(x),
                                                      y=float(y), z=float(z)),
               orientation=_quat(yaw))


def _transform(t_ns: int, parent: str, child: str, x: float, y: float, yaw: float) -> Any:
    return msg("geometry_msgs/msg/TransformStamped", header=header(t_ns, parent),
               child_frame_id=child,
               transform=msg("geometry_msgs/msg/Transform", translation=_vec(x, y, 0.0),
                             rotation=_quat(yaw)))


def _cloud(t_ns: int, frame: str, xyz: np.ndarray) -> Any:
    pts = np.ascontiguousarray(xyz, dtype="<f4")
    fields = [msg("sensor_msgs/msg/PointField", name=n, offset=o, datatype=7, count=1)
              for n, o in (("x", 0), ("y", 4), ("z", 8))]
    return msg("sensor_msgs/msg/PointCloud2", header=header(t_ns, frame), height=1,
               width=len(pts), fields=fields, is_bigendian=False, point_step=12,
               row_step=12 * len(pts), data=np.frombuffer(pts.tobytes(), dtype=np.uint8),
               is_dense=True)
