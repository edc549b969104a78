"""Turn a log into one pandas table per topic, for the message types metrics and plots use."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from kartci.errors import LogError
from kartci.logs.reader import messages
from kartci.logs.types import stamp_ns, yaw_of

Row = dict[str, Any]


def _odometry(m: Any) -> Row:
    p, q = m.pose.pose.position, m.pose.pose.orientation
    tw = m.twist.twist
    return {"x": p.x, "y": p.y, "z": p.z, "yaw": yaw_of(q), "qx": q.x, "qy": q.y, "qz": q.z,
            "qw": q.w, "vx": tw.linear.x, "vy": tw.linear.y, "wz": tw.angular.z}


def _joint_state(m: Any) -> Row:
    row: Row = {}
    for i, name in enumerate(m.name):
        if i < len(m.velocity):
            row[f"{name}.velocity"] = m.velocity[i]
        if i < len(m.position):
            row[f"{name}.position"] = m.position[i]
    return row


def _fields(*names: str) -> Callable[[Any], Row]:
    return lambda m: {n: getattr(m, n) for n in names}


FLATTENERS: dict[str, Callable[[Any], Row]] = {
    "nav_msgs/msg/Odometry": _odometry,
    "sensor_msgs/msg/JointState": _joint_state,
    "sensor_msgs/msg/Range": _fields("range"),
    "kartci_msgs/msg/LineSensor": _fields("left", "right"),
    "kartci_msgs/msg/LineControllerState": _fields("distance_estimate_m", "u2", "integral",
                                                   "sonar_stop"),
    "std_msgs/msg/String": _fields("data"),
    "sensor_msgs/msg/Joy": lambda m: {"axes": m.axes.tolist(), "buttons": m.buttons.tolist()},
    "kartci_msgs/msg/Collision": lambda m: {"other": m.other, "impulse_ns": m.impulse_ns,
                                            "duration_s": m.duration_s, "x": m.position.x,
                                            "y": m.position.y},
    "kartci_msgs/msg/KartCommand": _fields("steering_wheel_angle_rad", "acceleration_mps2",
                                           "brake_mps2", "reverse", "emergency_stop"),
    "kartci_msgs/msg/SolverStats": _fields("success", "status", "solve_ms", "iterations",
                                           "cost", "failures", "max_slack_m"),
    "nav_msgs/msg/Path": lambda m: {"xs": [p.pose.position.x for p in m.poses],
                                    "ys": [p.pose.position.y for p in m.poses]},
    "sensor_msgs/msg/Imu": lambda m: {"ax": m.linear_acceleration.x,
                                      "ay": m.linear_acceleration.y,
                                      "az": m.linear_acceleration.z, "wz": m.angular_velocity.z},
}


def _row(path: Path, topic: str, t_ns: int, m: Any, flat: Callable[[Any], Row]) -> Row:
    """A foreign log may define a type of the same name with other fields; say so in one line
    instead of failing in a flattener."""
    try:
        hdr = getattr(m, "header", None)
        t = stamp_ns(hdr) if hdr is not None else t_ns
        return {"t": t * 1e-9, **flat(m)}
    except (AttributeError, TypeError, ValueError) as err:
        raise LogError(f"{path}: {topic} ({m.__msgtype__}) lacks the fields kartci reads from "
                       f"that type ({err})") from err


def tables(path: Path, wanted: Sequence[str] | None = None) -> dict[str, pd.DataFrame]:
    """`t` (s, from the header stamp when there is one, else log time) plus flattened fields."""
    rows: dict[str, list[Row]] = defaultdict(list)
    for topic, t_ns, m in messages(path, wanted):
        flat = FLATTENERS.get(m.__msgtype__)
        if flat is not None:
            rows[topic].append(_row(path, topic, t_ns, m, flat))
    return {topic: pd.DataFrame(r) for topic, r in rows.items()}
