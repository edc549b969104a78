"""The type store: ROS 2 Humble's standard messages plus kartci's own (kartci_msgs)."""

from __future__ import annotations

import math
from functools import cache
from importlib import resources
from typing import Any

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore


@cache
def typestore() -> Typestore:
    store = get_typestore(Stores.ROS2_HUMBLE)
    extra: dict[str, Any] = {}
    for package in resources.files("kartci.logs").joinpath("msg").iterdir():
        if not package.is_dir():
            continue
        for item in package.iterdir():
            if item.name.endswith(".msg"):
                name = f"{package.name}/msg/{item.name.removesuffix('.msg')}"
                extra.update(get_types_from_msg(item.read_text(encoding="utf-8"), name))
    store.register(extra)
    return store


WORLD_FRAME = "map"  # the fixed frame of every world (REP 105's map)


def base_link(namespace: str) -> str:
    """A robot's body frame, as its tf publishes it: `<namespace>/base_link`."""
    return f"{namespace}/base_link"


def msg(typename: str, **fields: Any) -> Any:
    """Build a message of a registered type by keyword fields."""
    return typestore().types[typename](**fields)


def header(t_ns: int, frame_id: str) -> Any:
    sec, nsec = divmod(t_ns, 1_000_000_000)
    stamp = msg("builtin_interfaces/msg/Time", sec=sec, nanosec=nsec)
    return msg("std_msgs/msg/Header", stamp=stamp, frame_id=frame_id)


def yaw_of(q: Any) -> float:
    """Heading (rad) of a geometry_msgs/Quaternion, rotation about z."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def stamp_ns(hdr: Any) -> int:
    return int(hdr.stamp.sec) * 1_000_000_000 + int(hdr.stamp.nanosec)
