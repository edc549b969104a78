"""Reading files a user names without hanging or exhausting memory: every file input must be a
regular file (a FIFO would hang the open, /dev/zero would never end) within a size bound.

Kept out of `spec` because logs, baselines, summaries and mappings are read through it too. The
errors are OSError subclasses without the path, so each caller names the file in its own
error type; nothing here quotes a file's contents.
"""

from __future__ import annotations

import json
import math
import os
import stat
from pathlib import Path
from typing import Any

_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))
_FLAGS = (os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
          | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_BINARY", 0))
JSON_MAX_BYTES = 64 << 20  # a summary, metrics or baseline file; the real ones are under 100 KB
FIELD_MAX_CHARS = 40  # of a key named in a message


class RefusedFileError(OSError):
    """Not a regular file, or larger than allowed; str() is the reason, without the path."""


def size_text(n_bytes: int) -> str:
    """A byte limit as people write it (8 MiB, 64 KiB)."""
    return f"{n_bytes >> 20} MiB" if n_bytes >= 1 << 20 else f"{n_bytes >> 10} KiB"


def check_file(st: os.stat_result, limit_bytes: int | None) -> None:
    """RefusedFileError unless `st` is a regular file of at most `limit_bytes` (None: any)."""
    for is_kind, kind in _KINDS:
        if is_kind(st.st_mode):
            raise RefusedFileError(f"not a regular file ({kind})")
    if not stat.S_ISREG(st.st_mode):
        raise RefusedFileError("not a regular file")
    if limit_bytes is not None and st.st_size > limit_bytes:
        raise RefusedFileError(f"{st.st_size} bytes, more than the {size_text(limit_bytes)} "
                               "allowed")


def open_regular(path: Path, limit_bytes: int | None) -> int:
    """A read-only descriptor of a regular file. The stat comes before the open and the open
    does not block, so a FIFO or a device is refused without waiting or reading; the fstat
    after it catches a file swapped in between. OSError (FileNotFoundError, RefusedFileError)
    or ValueError (a NUL character in the path) otherwise."""
    check_file(path.stat(), limit_bytes)
    fd = os.open(path, _FLAGS)
    try:
        check_file(os.fstat(fd), limit_bytes)
    except BaseException:
        os.close(fd)
        raise
    return fd


def read_bytes(path: Path, limit_bytes: int) -> bytes:
    """The bytes of a regular file of at most `limit_bytes`, read as open_regular says."""
    fd = open_regular(path, limit_bytes)
    chunks: list[bytes] = []
    total = 0
    try:
        while total <= limit_bytes:  # a file may grow, or lie about its size (/proc)
            chunk = os.read(fd, limit_bytes + 1 - total)
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    finally:
        os.close(fd)
    if total > limit_bytes:
        raise RefusedFileError(f"more than the {size_text(limit_bytes)} allowed")
    return b"".join(chunks)


def check_log(path: Path) -> None:
    """A log must be a regular file, or a rosbag2 folder whose entries are regular files or
    folders; no size cap (MCAPs of hundreds of MB are normal). Raises as open_regular."""
    st = path.stat()
    if not stat.S_ISDIR(st.st_mode):
        os.close(open_regular(path, None))
        return
    for entry in sorted(path.iterdir()):
        if not entry.is_dir():
            try:
                os.close(open_regular(entry, None))
            except RefusedFileError as err:
                raise RefusedFileError(f"{_clip(entry.name)} in it: {err}") from err


def _clip(key: object) -> str:
    text = str(key)
    return text if len(text) <= FIELD_MAX_CHARS else text[: FIELD_MAX_CHARS - 1] + "…"


def out_of_range(doc: Any) -> str | None:
    """The dotted field of the first number in a parsed JSON document that a float cannot hold
    (a 400-digit integer; 1e999 or Infinity, read as inf), or None. Metrics are floats: such a
    number would fail later as an OverflowError, or compare as infinite."""
    stack: list[tuple[str, Any]] = [("", doc)]
    while stack:
        where, value = stack.pop()
        if isinstance(value, dict):
            stack += [(f"{where}.{_clip(k)}" if where else _clip(k), v)
                      for k, v in reversed(value.items())]
        elif isinstance(value, list):
            stack += [(f"{where}[{i}]", v) for i, v in reversed(list(enumerate(value)))]
        elif isinstance(value, float) and math.isinf(value):
            return where or "(top level)"
        elif isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 1000:
            try:
                float(value)
            except OverflowError:
                return where or "(top level)"
    return None


def is_number(x: Any) -> bool:
    """A finite int or float, not a bool: what a metric value or tolerance may be."""
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _no_constants(name: str) -> float:
    raise ValueError(f"{name} is not a number JSON allows")


def read_json(path: Path, limit_bytes: int = JSON_MAX_BYTES) -> Any:
    """JSON from a regular file of at most `limit_bytes`, without NaN / Infinity or a number a
    float cannot hold; any problem is a ValueError or OSError (RefusedFileError: not a regular
    file, or too large)."""
    try:
        doc = json.loads(read_bytes(path, limit_bytes), parse_constant=_no_constants)
    except RecursionError:
        raise ValueError("nested too deeply") from None
    field = out_of_range(doc)
    if field is not None:
        raise ValueError(f"{field}: a number out of range (beyond a float's ±1.8e308)")
    return doc


__all__ = ["JSON_MAX_BYTES", "RefusedFileError", "check_file", "check_log", "is_number",
           "open_regular", "out_of_range", "read_bytes", "read_json", "size_text"]
