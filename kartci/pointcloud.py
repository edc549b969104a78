"""Point clouds as files and as arrays: PLY (binary little-endian or ASCII, x y z vertices) for
maps, voxel down-sampling, and the xyz of a sensor_msgs/PointCloud2.

A map is a PLY file: `element vertex N` with float `x`, `y`, `z` properties in metres, in the
world (map) frame; other vertex properties are read past and ignored. kartci writes
binary_little_endian float32 x y z."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from kartci.atomic import write_bytes_atomic
from kartci.boundedio import read_bytes
from kartci.errors import LogError

Array = np.ndarray
# The hall's map (32 x 20 m) is 1 MB, 12 bytes a point; 256 MiB (22 M float32 points) holds a
# map of an area 250 times larger, an outdoor circuit's, and still stops a runaway file.
PLY_MAX_BYTES = 256 << 20
PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "<i2", "ushort": "<u2", "int": "<i4",
             "uint": "<u4", "float": "<f4", "double": "<f8", "int8": "i1", "uint8": "u1",
             "int16": "<i2", "uint16": "<u2", "int32": "<i4", "uint32": "<u4",
             "float32": "<f4", "float64": "<f8"}


def write_ply(path: Path, xyz: Array, comment: str = "") -> None:
    """Write points (N, 3), m, as a binary little-endian PLY (atomic)."""
    pts = np.ascontiguousarray(np.asarray(xyz, dtype="<f4").reshape(-1, 3))
    head = ["ply", "format binary_little_endian 1.0"]
    head += [f"comment {line}" for line in comment.splitlines() if line.strip()]
    head += [f"element vertex {len(pts)}", "property float x", "property float y",
             "property float z", "end_header"]
    write_bytes_atomic(path, ("\n".join(head) + "\n").encode("ascii") + pts.tobytes())


def read_ply(path: Path) -> Array:
    """The x y z (N, 3) float64 of a PLY file's vertices; a LogError naming the file when it is
    not a PLY kartci can read (binary big-endian, list properties before xyz)."""
    try:  # bounded: a FIFO named as the map would hang, /dev/zero fill the memory
        data = read_bytes(path, PLY_MAX_BYTES)
    except (OSError, ValueError) as err:  # RefusedFileError: not regular, too large
        reason = err.strerror if isinstance(err, OSError) and err.strerror else err
        raise LogError(f"{path}: cannot read the map: {reason}") from err
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply") or end < 0:
        raise LogError(f"{path}: not a PLY file (no 'ply' ... 'end_header')")
    lines = data[:end].decode("ascii", "replace").splitlines()
    fmt, count, props, element = "", 0, [], ""
    for number, line in enumerate(lines, 1):
        words = line.split()
        if words[:1] == ["format"] and len(words) > 1:
            fmt = words[1]
        elif words[:1] == ["element"] and len(words) == 3:
            element = words[1]
            if element == "vertex":
                count = int(words[2])
        elif words[:1] == ["property"] and element == "vertex":
            if words[1] == "list" or words[1] not in PLY_TYPES:
                raise LogError(f"{path}:{number}: unsupported vertex property (a list, or a "
                               "type other than PLY's scalar types)")
            props.append((words[2], PLY_TYPES[words[1]]))
    if not {"x", "y", "z"} <= {n for n, _ in props}:
        raise LogError(f"{path}: the PLY's vertices have no x, y, z")
    body = data[end + len(b"end_header\n"):]
    return _vertices(path, fmt, count, props, body)


def _vertices(path: Path, fmt: str, count: int, props: list[tuple[str, str]],
              body: bytes) -> Array:
    names = [n for n, _ in props]
    if fmt == "ascii":
        rows = body.decode("ascii", "replace").split("\n")[:count]
        try:
            table = np.array([[float(v) for v in r.split()[:len(names)]] for r in rows])
        except ValueError as err:  # its message quotes the value: the file may be anything
            raise LogError(f"{path}: an ASCII vertex value is not a number") from err
        if table.shape != (count, len(names)):
            raise LogError(f"{path}: expected {count} vertices of {len(names)} values")
        return np.column_stack([table[:, names.index(c)] for c in "xyz"])
    if fmt != "binary_little_endian":
        raise LogError(f"{path}: PLY format '{fmt[:40]}' not supported (binary_little_endian, "
                       "ascii)")
    dtype = np.dtype([(n, t) for n, t in props])
    if len(body) < count * dtype.itemsize:
        raise LogError(f"{path}: truncated: {count} vertices need {count * dtype.itemsize} "
                       f"bytes, {len(body)} present")
    v = np.frombuffer(body, dtype=dtype, count=count)
    return np.column_stack([v[c].astype(float) for c in "xyz"])


def voxel_downsample(xyz: Array, voxel_m: float) -> Array:
    """One point per occupied voxel (the centroid), ordered by voxel: deterministic."""
    if len(xyz) == 0:
        return np.zeros((0, 3))
    keys = np.floor(xyz / voxel_m).astype(np.int64)
    _, inverse, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    sums = np.zeros((len(counts), 3))
    np.add.at(sums, inverse.ravel(), xyz)
    out: Array = sums / counts[:, None]
    return out


def cloud_xyz(message: Any) -> Array:
    """x y z (N, 3) float64 of a PointCloud2 whose x, y, z are float32 fields."""
    offsets = {f.name: int(f.offset) for f in message.fields}
    step = int(message.point_step)
    raw = np.frombuffer(bytes(message.data), dtype=np.uint8)
    n = int(message.width) * int(message.height)
    dtype = np.dtype({"names": ["x", "y", "z"], "formats": ["<f4"] * 3,
                      "offsets": [offsets["x"], offsets["y"], offsets["z"]], "itemsize": step})
    v = np.frombuffer(raw.tobytes(), dtype=dtype, count=n)
    return np.column_stack([v["x"], v["y"], v["z"]]).astype(float)
