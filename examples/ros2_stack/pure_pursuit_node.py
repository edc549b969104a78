"""A pure-pursuit driver as a ROS 2 team writes one: an rclpy node that knows nothing of kartci.

It subscribes to `track` (std_msgs/String, the track as CSV: `x_m,y_m,...` rows; kartci publishes
it on `/kartci/track`) and `odom` (nav_msgs/Odometry), and answers every odometry message with one
`cmd_vel` (geometry_msgs/Twist: forward speed, yaw rate = speed x pure-pursuit curvature). Topic
names are relative, so a namespace or remapping places it, as in any launch file:

    python pure_pursuit_node.py --ros-args -r __ns:=/kart0 -r track:=/kartci/track \\
        -p use_sim_time:=true -p speed_mps:=5.0

With `use_sim_time` its clock (`get_clock().now()`, timers) follows `/clock`; its log lines
still carry wall-clock stamps (rclpy's logger stamps with the system clock whatever
use_sim_time says). It answers odometry (not a timer) so that each control tick gets exactly one
command computed from that tick's pose.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import rclpy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from std_msgs.msg import String


class PurePursuit(Node):  # type: ignore[misc]  # rclpy is untyped where mypy runs
    """Pure pursuit on a closed centreline; the speed follows the curvature ahead."""

    def __init__(self) -> None:
        super().__init__("pure_pursuit")
        self.speed_mps = float(self.declare_parameter("speed_mps", 5.0).value)
        self.lookahead_m = float(self.declare_parameter("lookahead_m", 3.5).value)
        self.max_lateral_accel = float(
            self.declare_parameter("max_lateral_accel_mps2", 4.0).value)
        self.xy: np.ndarray | None = None
        self.kappa = np.zeros(0)
        self.waiting: Odometry | None = None  # a pose that came before the track
        # `qos:=sensor_data`: best effort for odometry and commands, as many drivers publish;
        # `track_latched:=true`: the track as a latched (transient-local) topic, as a map is
        qos = qos_profile_sensor_data if self.declare_parameter(
            "qos", "default").value == "sensor_data" else 10
        track_qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL) if (
            self.declare_parameter("track_latched", False).value) else 10
        # subscriptions before the publisher: a simulator that waits for our publisher then
        # finds our subscriptions declared too
        self.create_subscription(String, "track", self.on_track, track_qos)
        self.create_subscription(Odometry, "odom", self.on_odom, qos)
        self.cmd = self.create_publisher(Twist, "cmd_vel", qos)
        self.count = 0

    def on_track(self, m: String) -> None:
        """The centreline from the CSV, resampled every 0.1 m, with its curvature."""
        rows = [line.split(",")[:2] for line in m.data.splitlines()
                if line.strip() and not line.lstrip().startswith("#")]
        pts = np.array(rows, dtype=float)
        pts = np.vstack([pts, pts[:1]])
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
        u = np.arange(0.0, s[-1], 0.1)
        xy = np.column_stack([np.interp(u, s, pts[:, 0]), np.interp(u, s, pts[:, 1])])
        a, b, c = np.roll(xy, 10, 0), xy, np.roll(xy, -10, 0)  # three points +-1 m
        cross = ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                 - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
        sides = np.hypot(*(b - a).T) * np.hypot(*(c - b).T) * np.hypot(*(c - a).T)
        self.kappa = np.abs(2 * cross / np.maximum(sides, 1e-9))
        self.xy = xy
        self.get_logger().info(f"track: {len(rows)} points, {s[-1]:.1f} m")
        if self.waiting is not None:
            self.on_odom(self.waiting)
            self.waiting = None

    def on_odom(self, m: Odometry) -> None:
        """One command per pose, once the track is known: DDS does not order messages of two
        topics, so the first pose can come before the track; it is answered when the track
        arrives (answering "stop" instead made the start depend on that race)."""
        if self.xy is None:
            self.waiting = m
            return
        out = Twist()
        if self.xy is not None:
            p, q = m.pose.pose.position, m.pose.pose.orientation
            yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
            v = m.twist.twist.linear.x
            i = int(np.argmin(np.hypot(self.xy[:, 0] - p.x, self.xy[:, 1] - p.y)))
            n = len(self.xy)
            gx, gy = self.xy[(i + round(self.lookahead_m / 0.1)) % n]
            alpha = math.atan2(gy - p.y, gx - p.x) - yaw
            curvature = 2.0 * math.sin(alpha) / self.lookahead_m
            ahead = self.kappa[(i + np.arange(round(max(8.0, 2 * v) / 0.1))) % n]
            speed = min(self.speed_mps,
                        math.sqrt(self.max_lateral_accel / max(float(ahead.max()), 1e-3)))
            out.linear.x, out.angular.z = speed, speed * curvature
        self.cmd.publish(out)
        self.count += 1
        if self.count % 500 == 0:
            self.get_logger().info(f"{self.count} commands")


def main() -> int:
    """Spin until shut down (SIGINT or SIGTERM)."""
    rclpy.init(args=sys.argv)
    node = PurePursuit()
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, rclpy.executors.ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
