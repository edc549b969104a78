"""A second node for the kart driver, in a process of its own: it republishes every
`/<ns>/odom` (nav_msgs/Odometry) on `/<ns>/odom_relay`, byte for byte, as a filter or a topic
bridge in a team's stack would. Run with `kart_driver.py --odom-topic odom_relay`, the driver
sees kartci's odometry only through this node (a stack of two nodes: docs/explain/lockstep.md).

eclipse-zenoh and rmw_zenoh's conventions only (the driver's `Ros2Node`), no kartci import:

    python odom_relay.py --connect tcp/127.0.0.1:PORT --namespace kart0
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time

import zenoh
from kart_driver import Ros2Node, config, typestore

ODOMETRY = "nav_msgs/msg/Odometry"


def main() -> int:
    """Relay until SIGTERM."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--connect", default=os.environ.get("KARTCI_ZENOH_ENDPOINT"))
    p.add_argument("--namespace", default=os.environ.get("KARTCI_NAMESPACE", "kart0"))
    p.add_argument("--domain-id", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    args = p.parse_args()
    if not args.connect:
        p.error("no endpoint: give --connect or set KARTCI_ZENOH_ENDPOINT")
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(0))
    session = zenoh.open(config(args.connect))
    node = Ros2Node(session, typestore(), args.domain_id, "odom_relay")
    ns = f"/{args.namespace}"
    out = node.raw_publisher(f"{ns}/odom_relay", ODOMETRY)
    node.raw_subscribe(f"{ns}/odom", ODOMETRY, out)
    print(f"odom_relay: {ns}/odom -> {ns}/odom_relay via {args.connect}", flush=True)
    while True:
        time.sleep(1)


if __name__ == "__main__":
    sys.exit(main())
