"""Fixed-layout CDR: a topic's messages serialised with one `struct` call each.

Most topics a run logs keep their layout from message to message: the same frame names, the
same number of joints and transforms; only numbers change. For such a topic the CDR bytes are a
template (lengths, strings, padding) with the numbers packed in, so `compile_fixed` reads the
layout off the topic's first message and generates a function that checks every string and
length against it and packs the numbers in one call. A message that differs (another frame
name, another joint count, a field of another kind) gets None and is serialised by rosbags as
before, as is a type it cannot lay out (a wide string); the first message is checked
against rosbags' bytes when the function is made, and a topic whose bytes differ keeps
rosbags.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.typesys.store import Typestore

Serialise = Callable[[Any], bytes | None]

_FORMAT = {"bool": "?", "byte": "b", "char": "B", "int8": "b", "uint8": "B", "int16": "h",
           "uint16": "H", "int32": "i", "uint32": "I", "int64": "q", "uint64": "Q",
           "float32": "f", "float64": "d"}
_HEADER = b"\x00\x01\x00\x00"  # CDR, little-endian, no options


class _UnsupportedError(Exception):
    """A layout this module does not generate code for."""


class _Layout:
    """The template being built: struct format, the argument of each field (an expression or a
    constant), the checks that keep it valid and the code that names nested values."""

    def __init__(self, store: Typestore) -> None:
        self.store = store
        self.pos = 0  # bytes after the 4-byte header
        self.fmt = ["<4s"]
        self.args = ["C0"]
        self.consts: list[object] = [_HEADER]
        self.checks: list[str] = []
        self.lines: list[str] = []
        self.names = 0

    def local(self, expr: str) -> str:
        """A local variable holding `expr`."""
        self.names += 1
        name = f"v{self.names}"
        self.lines.append(f"    {name} = {expr}")
        return name

    def const(self, value: object) -> str:
        """A constant argument."""
        self.consts.append(value)
        return f"C{len(self.consts) - 1}"

    def align(self, size: int) -> None:
        pad = -self.pos % size
        if pad:
            self.fmt.append(f"{pad}x")
            self.pos += pad

    def number(self, kind: str, expr: str) -> None:
        code = _FORMAT.get(kind)
        if code is None:
            raise _UnsupportedError(kind)
        size = struct.calcsize(code)
        self.align(size)
        self.fmt.append(code)
        self.args.append(expr)
        self.pos += size

    def string(self, value: object, expr: str) -> None:
        if not isinstance(value, str):
            raise _UnsupportedError("a string field that holds no str")
        self.checks.append(f"{expr} == {self.const(value)}")
        data = value.encode() + b"\x00"
        self.align(4)
        self.fmt.append(f"I{len(data)}s")
        self.args += [self.const(len(data)), self.const(data)]
        self.pos += 4 + len(data)

    def raw(self, kind: str, count: int, expr: str) -> None:
        """`count` numbers of `kind` from a numpy array, as their bytes."""
        code = _FORMAT.get(kind)
        if code is None:
            raise _UnsupportedError(kind)
        size = struct.calcsize(code) * count
        name = self.local(f"{expr}.tobytes()")
        self.checks.append(f"len({name}) == {size}")
        self.fmt.append(f"{size}s")
        self.args.append(name)
        self.pos += size

    def field(self, desc: tuple[Any, Any], value: object, expr: str) -> None:
        node, detail = desc
        if node == Nodetype.NAME:
            self.message(detail, value, self.local(expr))
        elif node == Nodetype.BASE:
            if detail[0] == "string":
                self.string(value, expr)
            else:
                self.number(detail[0], expr)
        elif node == Nodetype.ARRAY:
            self.items(detail[0], value, expr, detail[1], counted=False)
        else:
            self.align(4)
            count = len(value)  # type: ignore[arg-type]  # a sequence field
            self.checks.append(f"len({expr}) == {count}")
            self.fmt.append("I")
            self.args.append(self.const(count))
            self.pos += 4
            self.items(detail[0], value, expr, count, counted=True)

    def items(self, sub: tuple[Any, Any], value: Any, expr: str, count: int,
              counted: bool) -> None:
        if sub[0] == Nodetype.BASE and sub[1][0] != "string":
            if count or not counted:  # an empty sequence is not aligned
                self.align(struct.calcsize(_FORMAT.get(sub[1][0], "B")))
            self.raw(sub[1][0], count, expr)
            return
        seq = self.local(expr)
        for i in range(count):
            self.field(sub, value[i], f"{seq}[{i}]")

    def message(self, typename: str, value: object, expr: str) -> None:
        if getattr(value, "__msgtype__", None) != typename:
            raise _UnsupportedError(f"not a {typename}")
        self.checks.append(f"{expr}.__msgtype__ == {self.const(typename)}")
        for name, desc in self.store.fielddefs[typename][1]:
            self.field(desc, getattr(value, name), f"{expr}.{name}")


def compile_fixed(store: Typestore, message: Any) -> Serialise | None:
    """A serialiser for messages laid out like `message` (None for a layout it cannot
    template, or one whose bytes would differ from rosbags')."""
    layout = _Layout(store)
    try:
        layout.message(message.__msgtype__, message, "m")
    except (_UnsupportedError, KeyError, TypeError):
        return None
    fmt = struct.Struct("".join(layout.fmt))
    # nested values named first, then every check (`and` stops at the first that fails), then
    # one pack; anything that raises on the way (a field missing, a value of another kind) is
    # a message this layout does not fit
    body = [*layout.lines, f"    if not ({' and '.join(layout.checks) or 'True'}):",
            "        return None", f"    return PACK({', '.join(layout.args)})"]
    code = "\n".join(["def serialise(m):", "  try:", *(f"  {line}" for line in body),
                      "  except Exception:", "    return None"])
    scope: dict[str, Any] = {"PACK": fmt.pack}
    scope.update({f"C{i}": c for i, c in enumerate(layout.consts)})
    exec(compile(code, f"<cdr {message.__msgtype__}>", "exec"), scope)
    serialise: Serialise = scope["serialise"]
    try:
        ok = serialise(message) == bytes(store.serialize_cdr(message, message.__msgtype__))
    except Exception:  # any failure: this topic keeps rosbags
        ok = False
    return serialise if ok else None
