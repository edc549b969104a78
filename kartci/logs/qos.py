"""QoS metadata on a log's channels, as rosbag2 writes it (`offered_qos_profiles`, a YAML list of
rmw QoS profiles): `ros2 bag play` and Foxglove replay a latched topic (/tf_static, the robot's
URDF, the track) as transient-local, so a late subscriber still gets it."""

from __future__ import annotations

from enum import IntEnum


class Durability(IntEnum):
    """rmw_qos_durability_policy_t."""

    TRANSIENT_LOCAL = 1
    VOLATILE = 2


RELIABLE = 1  # rmw_qos_reliability_policy_t
KEEP_LAST = 1  # rmw_qos_history_policy_t
AUTOMATIC = 1  # rmw_qos_liveliness_policy_t


def offered_qos_profiles(latched: bool) -> str:
    """One publisher's profile: reliable, keep-last (depth 1 latched, else 10), transient-local
    when latched, else volatile; deadline, lifespan and lease at the rmw default (0 = none)."""
    durability = Durability.TRANSIENT_LOCAL if latched else Durability.VOLATILE
    zero = "\n    sec: 0\n    nsec: 0"
    return (f"- history: {KEEP_LAST}\n  depth: {1 if latched else 10}\n"
            f"  reliability: {RELIABLE}\n  durability: {int(durability)}\n"
            f"  deadline:{zero}\n  lifespan:{zero}\n  liveliness: {AUTOMATIC}\n"
            f"  liveliness_lease_duration:{zero}\n  avoid_ros_namespace_conventions: false\n")
