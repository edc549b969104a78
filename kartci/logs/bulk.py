"""A topic's table decoded in bulk from its CDR bytes: the table tables() makes message by
message, at a fraction of the cost.

A run logs thousands of messages per topic that share one layout: the same length, frame names,
joint and wheel names and array lengths; only numbers change. The layout is read off one
message, decoded by rosbags (the reference), by walking its type's definition as rosbags'
decoder does; every message whose bytes agree with the reference's at each string and each
array length (its structure) has that layout, and its numbers are read as numpy columns at the
reference's offsets. The flattener then runs once on a message whose numbers are those columns
(an array of k elements: a (k, n) array), strings taken from the reference.

The flattened reference row decides the table's column names and dtypes (pandas' own inference
from that row) and must equal the columns' first row bit for bit, else the topic is left to the
exact path (None), as is a topic of more than _MAX_GROUPS layouts, a layout this module does
not read (wide strings, uint64, float128, bool arrays) or a flattener that does not take
columns.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import cache
from types import SimpleNamespace
from typing import Any

import numpy as np
import pandas as pd
from rosbags.interfaces import Nodetype
from rosbags.serde.utils import align as rosbags_align
from rosbags.typesys.store import Typestore

from kartci.logs.types import typestore

Flatten = Callable[[Any], dict[str, Any]]
# CDR little-endian numbers as numpy reads them (uint64 left out: pandas makes such Python ints
# uint64 or object depending on their values)
_DTYPES = {"bool": "u1", "byte": "i1", "char": "u1", "int8": "i1", "uint8": "u1",
           "int16": "<i2", "uint16": "<u2", "int32": "<i4", "uint32": "<u4", "int64": "<i8",
           "float32": "<f4", "float64": "<f8"}
_MAX_GROUPS = 16  # layouts per topic; more (a string that changes often): message by message
_MIN_MESSAGES = 16  # fewer (a course, a scenario): message by message, as cheap


class _UnfitError(Exception):
    """A layout this module does not read."""


def standard(store: Typestore, msgtype: str) -> bool:
    """Whether `store` (a log's types) defines `msgtype` as kartci's standard store does."""
    try:
        return bool(store.generate_msgdef(msgtype, ros_version=2) == _definition(msgtype))
    except Exception:  # a broken or missing definition fails in many ways
        return False


@cache
def _definition(msgtype: str) -> tuple[str, str]:
    return typestore().generate_msgdef(msgtype, ros_version=2)


def _aligned(pos: int, size: int) -> int:
    return (pos + size - 1) // size * size


class _Walk:
    """One layout read off the reference message: its columns over `rows` (the bytes of the
    messages that share it, one row each) and the byte positions of its structure."""

    def __init__(self, store: Typestore, body: bytes, rows: np.ndarray) -> None:
        self.store, self.body, self.rows = store, body, rows
        self.fixed: list[int] = [0, 1]  # encapsulation: CDR, little endian

    def message(self, typename: str, ref: Any, pos: int) -> tuple[SimpleNamespace, int]:
        out: dict[str, Any] = {}
        for name, desc in self.store.fielddefs[typename][1]:
            pos = _aligned(pos, rosbags_align(desc, self.store))
            out[name], pos = self.field(desc, getattr(ref, name), pos)
        return SimpleNamespace(**out), pos

    def field(self, desc: Any, ref: Any, pos: int) -> tuple[Any, int]:
        node, detail = desc
        if node == Nodetype.NAME:
            return self.message(detail, ref, pos)
        if node == Nodetype.BASE:
            if detail[0] == "string":
                return ref, self.string(pos)
            return self.numbers(detail[0], 1, pos, scalar=True)
        sub, count = detail
        if node == Nodetype.SEQUENCE:
            self.fixed.extend(range(4 + pos, 8 + pos))
            count = len(ref)
            pos += 4
            if sub[0] == Nodetype.BASE and sub[1][0] != "string" and count:
                pos = _aligned(pos, np.dtype(_DTYPES.get(sub[1][0], "u1")).itemsize)
        if sub[0] == Nodetype.BASE and sub[1][0] != "string":
            if sub[1][0] == "bool":  # rosbags hands out numpy's view of the bytes as bool
                raise _UnfitError("bool array")
            return self.numbers(sub[1][0], count, pos, scalar=False)
        items = []
        for i in range(count):
            if i or node == Nodetype.SEQUENCE:
                pos = _aligned(pos, rosbags_align(sub, self.store))
            item, pos = self.field(sub, ref[i], pos)
            items.append(item)
        return items, pos

    def string(self, pos: int) -> int:
        """The end of the string at `pos`; its bytes are structure."""
        end = pos + 4 + int.from_bytes(self.body[pos:pos + 4], "little")
        self.fixed.extend(range(4 + pos, 4 + end))
        return end

    def numbers(self, kind: str, count: int, pos: int, scalar: bool) -> tuple[Any, int]:
        """Column(s) of `count` numbers at `pos`: one array (scalar) or a (count, n) array."""
        if kind not in _DTYPES:
            raise _UnfitError(kind)
        dtype = np.dtype(_DTYPES[kind])
        end = pos + dtype.itemsize * count
        cols = self.rows[:, 4 + pos:4 + end].copy().view(dtype)
        cols = cols != 0 if kind == "bool" else cols.astype(dtype.newbyteorder("="))
        return (cols[:, 0] if scalar else cols.T), end


def _layout(store: Typestore, msgtype: str, ref: Any, data: bytes, rows: np.ndarray
            ) -> tuple[SimpleNamespace, list[int]]:
    """The columnar message of `rows`, laid out as `data` (the reference's bytes, decoded as
    `ref`), and the positions of its structure."""
    if data[:2] != b"\x00\x01":
        raise _UnfitError("not little-endian CDR")
    walk = _Walk(store, data[4:], rows)
    columns, end = walk.message(msgtype, ref, 0)
    if not 0 <= len(data) - 4 - end <= 3:  # rosbags' own tolerance for trailing bytes
        raise _UnfitError("length")
    return columns, walk.fixed


def _stamps(columns: SimpleNamespace, t_log: np.ndarray) -> np.ndarray:
    """`t` (s): the header stamp where the type has a header (tables' rule), else log time."""
    hdr = getattr(columns, "header", None)
    if hdr is None:
        return t_log.astype(np.float64) * 1e-9
    ns = hdr.stamp.sec.astype(np.int64) * 1_000_000_000 + hdr.stamp.nanosec.astype(np.int64)
    return np.asarray(ns.astype(np.float64) * 1e-9)


Group = tuple[np.ndarray, dict[str, np.ndarray], pd.Series]  # rows, columns, dtypes


def _group(flat: Flatten, columns: SimpleNamespace, idx: np.ndarray, t_log: np.ndarray,
           row0: dict[str, Any]) -> Group:
    """The group's flattened columns (numpy dtypes, or objects for pandas' strings) and the
    dtypes pandas gives the reference's row `row0`; _UnfitError unless their first row is
    `row0`, bit for bit."""
    try:
        got = {"t": _stamps(columns, t_log), **flat(columns)}
    except Exception as err:  # a flattener written for one message only
        raise _UnfitError(str(err)) from err
    if list(got) != list(row0):
        raise _UnfitError("columns")
    dtypes = pd.DataFrame([row0]).dtypes
    out: dict[str, np.ndarray] = {}
    for key, value in got.items():
        dtype = dtypes[key]
        if isinstance(value, str):
            col = np.full(len(t_log), value, dtype=object)
        elif (isinstance(value, np.ndarray) and value.shape == t_log.shape
              and isinstance(dtype, np.dtype) and (value.dtype.kind == "O") == (dtype.kind == "O")):
            col = value.astype(dtype)  # numbers, or lists (of a flattener's _listed)
        else:
            raise _UnfitError(key)
        if not _same(col[0], row0[key]):
            raise _UnfitError(key)
        out[key] = col
    return idx, out, dtypes


def _same(fast: Any, slow: Any) -> bool:
    """Whether a column's first value is the reference row's, bit for bit."""
    if isinstance(fast, np.generic):
        return np.asarray(fast).tobytes() == np.asarray(slow, fast.dtype).tobytes()
    return type(fast) is type(slow) and repr(fast) == repr(slow)


def bulk_table(store: Typestore, msgtype: str, datas: Sequence[bytes], t_log: np.ndarray,
               reference: Callable[[int], tuple[Any, dict[str, Any]] | None], flat: Flatten
               ) -> pd.DataFrame | None:
    """The table of one topic's messages (`datas`: their CDR bytes, `t_log`: log times ns, in
    log order), equal to the one tables_of makes; `reference(i)`: message i decoded by rosbags
    and its row as tables_of makes it (None: it does not decode). None: read this topic
    message by message."""
    if len(datas) < _MIN_MESSAGES:
        return None
    by_length: dict[int, list[int]] = {}
    for i, data in enumerate(datas):
        by_length.setdefault(len(data), []).append(i)
    parts: list[Group] = []
    for length, members in by_length.items():
        idx = np.array(members)
        rows = np.frombuffer(b"".join([datas[i] for i in members]), np.uint8).reshape(-1,
                                                                                      length)
        todo = np.ones(len(members), bool)
        while todo.any():
            if len(parts) >= _MAX_GROUPS:
                return None
            k = int(np.argmax(todo))
            found = reference(int(idx[k]))
            if found is None:
                return None
            ref, row0 = found
            try:
                _, fixed = _layout(store, msgtype, ref, datas[idx[k]], rows[k:k + 1])
                same = todo & (rows[:, fixed] == rows[k, fixed]).all(axis=1)
                columns, _ = _layout(store, msgtype, ref, datas[idx[k]], rows[same])
                parts.append(_group(flat, columns, idx[same], t_log[idx[same]], row0))
            except _UnfitError:
                return None
            todo &= ~same
    return _joined(parts, len(datas))


def _joined(parts: list[Group], n: int) -> pd.DataFrame | None:
    """The groups' columns in log order; None when groups differ in columns or dtypes."""
    _, first, dtypes = parts[0]
    if any(list(cols) != list(first) or not types.equals(dtypes) for _, cols, types in parts):
        return None
    if len(parts) == 1:
        out = first
    else:
        out = {key: np.empty(n, col.dtype) for key, col in first.items()}
        for idx, cols, _ in parts:
            for key, col in cols.items():
                out[key][idx] = col
    return pd.DataFrame({key: col if isinstance(dtypes[key], np.dtype)
                         else pd.array(col, dtype=dtypes[key]) for key, col in out.items()})


__all__ = ["bulk_table", "standard"]
