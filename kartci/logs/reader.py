"""Read any log (ROS 1 .bag, rosbag2 directory, bare .mcap) through rosbags' AnyReader.

Every failure of the underlying readers, including the bare AssertionError of some damaged ROS 1
bags and the struct.error of a truncated MCAP, becomes one LogError that names the file.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.rosbag1 import ReaderError as Ros1ReaderError
from rosbags.rosbag2 import ReaderError as Ros2ReaderError

from kartci.errors import LogError
from kartci.logs.types import typestore

_READ_ERRORS = (AnyReaderError, Ros1ReaderError, Ros2ReaderError, AssertionError, struct.error,
                EOFError, ValueError, KeyError, IndexError, OSError, TypeError)


@dataclass(frozen=True)
class TopicInfo:
    topic: str
    msgtype: str
    count: int


@contextmanager
def open_log(path: Path) -> Iterator[AnyReader]:
    if not path.exists():
        raise LogError(f"{path}: no such file or directory")
    try:
        reader = AnyReader([path], default_typestore=typestore())
        reader.open()
    except _READ_ERRORS as err:
        raise LogError(f"{path}: cannot read log ({type(err).__name__}: {err})") from None
    try:
        yield reader
    finally:
        reader.close()


def topics(path: Path) -> list[TopicInfo]:
    with open_log(path) as reader:
        return [TopicInfo(c.topic, c.msgtype, c.msgcount) for c in reader.connections]


def messages(path: Path, wanted: Sequence[str] | None = None) -> Iterator[tuple[str, int, Any]]:
    """Yield (topic, log time ns, message) in time order, for the wanted topics (default all)."""
    with open_log(path) as reader:
        conns = [c for c in reader.connections if wanted is None or c.topic in wanted]
        try:
            for conn, t_ns, raw in reader.messages(connections=conns):
                yield conn.topic, t_ns, reader.deserialize(raw, conn.msgtype)
        except _READ_ERRORS as err:
            raise LogError(f"{path}: damaged log ({type(err).__name__}: {err})") from None
