"""Fixed frames of a URDF (sensor mounts), read once so they need not be simulated as links."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from kartci.errors import SpecError


def rpy_matrix(roll: float, pitch: float, yaw: float) -> NDArray[np.float64]:
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def fixed_frames(path: Path, root: str = "base_link") -> dict[str, tuple[NDArray[np.float64],
                                                                          NDArray[np.float64]]]:
    """Every link reachable from `root` through fixed joints: (position, rotation) in root."""
    try:
        tree = ET.parse(path)
    except (OSError, ET.ParseError) as err:
        raise SpecError(f"{path}: cannot read URDF ({err})") from None
    children: dict[str, list[tuple[str, NDArray[np.float64], NDArray[np.float64]]]] = {}
    for joint in tree.getroot().iter("joint"):
        if joint.get("type") != "fixed":
            continue
        parent = joint.find("parent")
        child = joint.find("child")
        if parent is None or child is None:
            continue
        origin = joint.find("origin")
        xyz = np.fromstring(origin.get("xyz", "0 0 0") if origin is not None else "0 0 0", sep=" ")
        rpy = np.fromstring(origin.get("rpy", "0 0 0") if origin is not None else "0 0 0", sep=" ")
        children.setdefault(parent.get("link", ""), []).append(
            (child.get("link", ""), xyz, rpy_matrix(*rpy)))
    frames: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]]
    frames = {root: (np.zeros(3), np.eye(3))}
    stack = [root]
    while stack:
        link = stack.pop()
        pos, rot = frames[link]
        for child_link, xyz, r in children.get(link, []):
            frames[child_link] = (pos + rot @ xyz, rot @ r)
            stack.append(child_link)
    return frames
