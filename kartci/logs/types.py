"""The type store: ROS 2 Humble's standard messages plus kartci's own (kartci_msgs)."""

from __future__ import annotations

import math
from functools import cache
from importlib import resources
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from kartci.logs.damage import detail

_IDL_SEP = "=" * 80 + "\n"


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
SCENARIO_TOPIC = "/kartci/scenario"  # std_msgs/String: the scenario run, as JSON, at t = 0


def base_link(namespace: str) -> str:
    """A robot's body frame, as its tf publishes it: `<namespace>/base_link`."""
    return f"{namespace}/base_link"


def for_writing(log_types: Typestore) -> Typestore:
    """kartci's store plus the types only a log defines (a ROS 1 bag's turtlesim/msg/Pose), so
    any log's messages can be written as ROS 2 CDR. Where both define a type, the ROS 2 one wins:
    the copy is meant for ROS 2 tools, and a ROS 1 Header's `seq` is simply not written."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register({k: v for k, v in typestore().fielddefs.items() if k not in store.fielddefs})
    store.register({k: v for k, v in log_types.fielddefs.items() if k not in store.fielddefs})
    return store


def _parse(msgtype: str, fmt: str, text: str) -> dict[str, Any]:
    if fmt == "msg":
        return dict(get_types_from_msg(text, msgtype))
    if not text.startswith(f"{_IDL_SEP}IDL: "):
        return dict(get_types_from_idl(text))
    found: dict[str, Any] = {}
    for part in text.split(_IDL_SEP)[1:]:
        found.update(get_types_from_idl(part.split("\n", 1)[1]))
    return found


def from_definitions(defs: list[tuple[str, str, str]]) -> tuple[Typestore, list[str]]:
    """A store of the types a log defines, each (msgtype, "msg" | "idl" | "", text), and the
    problems met. Used when a log is read without rosbags' AnyReader (salvaged): a definition
    that does not parse or clashes with another only loses its own topics, and types the log
    does not define come from kartci's store, as AnyReader's default_typestore would give."""
    store = get_typestore(Stores.EMPTY)
    problems: list[str] = []
    for msgtype, fmt, text in defs:
        if not fmt or msgtype in store.fielddefs:
            continue
        try:
            store.register(_parse(msgtype, fmt, text))
        except Exception as err:  # a damaged definition raises anything
            problems.append(f"definition of {msgtype} unusable ({detail(str(err))})")
    missing = {m for m, _, _ in defs} - store.fielddefs.keys()
    if missing & typestore().fielddefs.keys():
        store.register({k: v for k, v in typestore().fielddefs.items()
                        if k not in store.fielddefs})
    return store, problems


def msg(typename: str, **fields: Any) -> Any:
    """Build a message of a registered type by keyword fields."""
    return typestore().types[typename](**fields)


def header(t_ns: int, frame_id: str) -> Any:
    """A std_msgs/Header stamped `t_ns`. Built by the classes, fields in the .msg's order: a
    run makes one for nearly every message, and `msg`'s keywords cost twice the object."""
    types = typestore().types
    sec, nsec = divmod(t_ns, 1_000_000_000)
    return types["std_msgs/msg/Header"](types["builtin_interfaces/msg/Time"](sec, nsec),
                                        frame_id)


def yaw_of(q: Any) -> float:
    """Heading (rad) of a geometry_msgs/Quaternion, rotation about z."""
    return yaw_from(q.x, q.y, q.z, q.w)


def yaw_from(x: float, y: float, z: float, w: float) -> float:
    """Heading (rad) of the quaternion (x, y, z, w), rotation about z."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def yaws_from(quat: np.ndarray) -> np.ndarray:
    """`yaw_from` of each row (x, y, z, w) of an n x 4 array, in one pass: the same bits in
    kartci's pinned process, where numpy's arctan2 is libm's atan2."""
    x, y, z, w = np.asarray(quat, float).reshape(-1, 4).T
    return np.asarray(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))


def stamp_ns(hdr: Any) -> int:
    return int(hdr.stamp.sec) * 1_000_000_000 + int(hdr.stamp.nanosec)
