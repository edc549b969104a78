"""Run under a ROS 2 Python (never kartci's): one rclpy node that publishes its tag on
`/kartci_chatter` every 50 ms, prints `heard <tag>` when it first hears another node's tag and,
once its stdin closes, `got <JSON list>` of every tag it received (its own included), then
shuts down through rclpy. Imports no kartci code.

    python chatter.py TAG
"""

from __future__ import annotations

import json
import sys
import threading

import rclpy
from std_msgs.msg import String

TOPIC = "/kartci_chatter"


def main() -> int:
    """Chatter until stdin closes."""
    tag = sys.argv[1]
    rclpy.init(args=[])
    node = rclpy.create_node(f"chatter_{tag}")
    got: set[str] = set()

    def hear(m: String) -> None:
        if m.data not in got and m.data != tag:
            print("heard", m.data, flush=True)
        got.add(m.data)

    node.create_subscription(String, TOPIC, hear, 10)
    pub = node.create_publisher(String, TOPIC, 10)
    node.create_timer(0.05, lambda: pub.publish(String(data=tag)))
    done = threading.Event()

    def wait_for_eof() -> None:
        sys.stdin.read()
        done.set()

    threading.Thread(target=wait_for_eof, daemon=True).start()
    print("up", flush=True)
    while not done.is_set():
        rclpy.spin_once(node, timeout_sec=0.05)
    print("got", json.dumps(sorted(got)), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
