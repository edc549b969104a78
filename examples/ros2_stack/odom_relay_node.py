"""A relay as many ROS 2 stacks have one (a filter, a frame change, a topic bridge): an rclpy
node that knows nothing of kartci, republishing every `odom` message on `odom_relay`.

With `pure_pursuit_node.py` remapped to read `odom_relay`, the two make a stack of two nodes in
two processes: kartci's odometry reaches the driver only through this node, so a lockstep that
waited for the driver alone would race it (docs/explain/lockstep.md).

    python odom_relay_node.py --ros-args -r __ns:=/kart0 -p qos:=sensor_data
"""

from __future__ import annotations

import sys

import rclpy
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data


class OdomRelay(Node):  # type: ignore[misc]  # rclpy is untyped where mypy runs
    """`odom` in, the same message out on `odom_relay`."""

    def __init__(self) -> None:
        super().__init__("odom_relay")
        qos = qos_profile_sensor_data if self.declare_parameter(
            "qos", "default").value == "sensor_data" else 10
        self.out = self.create_publisher(Odometry, "odom_relay", qos)
        self.create_subscription(Odometry, "odom", self.out.publish, qos)


def main() -> int:
    """Spin until shut down (SIGINT or SIGTERM)."""
    rclpy.init(args=sys.argv)
    node = OdomRelay()
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
