"""What only the line tracker knows of its own messages: how a log's tables flatten them.
Registered with the kind (`ROBOT`), read by the kind-neutral log code."""

from __future__ import annotations

from collections.abc import Mapping

from kartci.core import Flattener, fields

FLATTENERS: Mapping[str, Flattener] = {
    "kartci_msgs/msg/LineSensor": fields("left", "right"),
    "kartci_msgs/msg/LineControllerState": fields("distance_estimate_m", "u2", "integral",
                                                  "sonar_stop"),
}
