"""Fixed frames of a URDF (sensor mounts), read once so they need not be simulated as links."""

from __future__ import annotations

import hashlib
import re
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kartci.atomic import write_text_atomic
from kartci.errors import SpecError
from kartci.logs import msg
from kartci.project import BUILTIN_MODELS
from kartci.scenario.yamlio import read_bytes_bounded, read_text_bounded

URDF_MAX_BYTES = 8 << 20  # a URDF (meshes are files of their own); the shipped ones are 6 KB


def urdf_path(model: Any) -> Path:
    """A robot model's URDF: an absolute path, as loading the scenario resolved it on its
    project's model path (`kartci.scenario.load.in_project`), or, in a scenario built by hand,
    a name relative to `<kind>/` in kartci's own models."""
    path = Path(str(model.urdf))
    if path.is_absolute():
        return path
    builtin = BUILTIN_MODELS / str(model.kind) / path
    if ".." not in path.parts and builtin.is_file():
        return builtin
    raise SpecError(f"{model.kind} URDF {str(path)[:120]!r}: not found on the model path of "
                    "the project the scenario was loaded in, nor in kartci's models")


def parsed(path: Path) -> ET.Element:
    """The URDF's root element, read as a bounded regular file (a FIFO or /dev/zero named as a
    URDF would hang or fill the memory); a SpecError naming the file otherwise."""
    try:
        return ET.fromstring(read_bytes_bounded(path, URDF_MAX_BYTES))
    except ET.ParseError as err:  # expat's message gives the place, not the text
        raise SpecError(f"{path}: cannot read URDF ({err})") from err


def urdf_text(path: Path) -> str:
    """The URDF's text, read within URDF_MAX_BYTES."""
    return read_text_bounded(path, URDF_MAX_BYTES)


def rpy_matrix(roll: float, pitch: float, yaw: float) -> NDArray[np.float64]:
    """Rotation matrix of URDF roll, pitch, yaw (rad): about fixed x, then y, then z."""
    cr, sr, cp, sp, cy, sy = (np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch),
                              np.cos(yaw), np.sin(yaw))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def fixed_frames(path: Path, root: str = "base_link") -> dict[str, tuple[NDArray[np.float64],
                                                                          NDArray[np.float64]]]:
    """Every link reachable from `root` through fixed joints: (position, rotation) in root."""
    children: dict[str, list[tuple[str, NDArray[np.float64], NDArray[np.float64]]]] = {}
    for joint in parsed(path).iter("joint"):
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


def physics_urdf(path: Path, edit: Callable[[ET.Element], None] | None = None) -> Path:
    """The URDF with its frame-only links (fixed joint, no collision: sensor mounts) removed,
    then changed by `edit` if given (a robot's parameters overriding the file's, e.g. masses).

    Such links cost a third of a physics step each robot, and PyBullet's own
    URDF_MERGE_FIXED_LINKS loses the base's centre of mass (seen with 3.2.7), so they are
    dropped here and their frames come from `fixed_frames` instead. Written once to a cache
    folder, named by content.
    """
    root = parsed(path)
    links = {link.get("name"): link for link in root.findall("link")}
    for joint in root.findall("joint"):
        child = joint.find("child")
        name = child.get("link") if child is not None else None
        link = links.get(name)
        if (joint.get("type") == "fixed" and link is not None
                and link.find("collision") is None):
            root.remove(joint)
            root.remove(link)
    if edit is not None:
        edit(root)
    text = ET.tostring(root, encoding="unicode")
    digest = hashlib.sha256(text.encode()).hexdigest()[:16]
    out = Path(tempfile.gettempdir()) / "kartci-urdf" / f"{path.stem}-{digest}.urdf"
    if not out.exists():  # content-addressed: parallel writers write the same bytes
        write_text_atomic(out, text)
    return out


_LINK_REF = re.compile(r'(<link\s+name=|<parent\s+link=|<child\s+link=)(["\'])([^"\']+)\2')


def prefixed_urdf(text: str, namespace: str) -> str:
    """A URDF whose links are named as the robot's tf frames: `<namespace>/<link>`."""
    return _LINK_REF.sub(lambda m: f"{m[1]}{m[2]}{namespace}/{m[3]}{m[2]}", text)


def robot_descriptions(scenario: Any) -> list[tuple[str, Any]]:
    """`/<agent>/robot_description` (std_msgs/String, the URDF with tf-prefixed links) of every
    agent whose model has a URDF: what Foxglove's 3D panel and robot_state_publisher read."""
    out = []
    for name, spec in scenario.agents.items():
        if getattr(spec.model, "urdf", None) is None:
            continue
        text = urdf_text(urdf_path(spec.model))
        out.append((f"/{name}/robot_description",
                    msg("std_msgs/msg/String", data=prefixed_urdf(text, name))))
    return out
