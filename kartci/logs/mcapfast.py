"""The raw messages of a rosbag2 MCAP (a folder with one .mcap file, or a bare .mcap) as rosbags
reads them, in its order, without its per-message layers: each record is taken apart with one
struct call over the chunk's (or the mapped file's) bytes instead of a BytesIO and three reads
per message, and no generator per layer (AnyReader, the rosbag2 reader, the storage).

A record that does not hold together is left to rosbags: its own reader is started over and the
messages already returned are skipped, so it fails where and how it always did (and
kartci.logs.reader salvages the rest as before). Logs of any other kind (ROS 1, sqlite3,
several files, per-message compression) are read by rosbags alone. This walks rosbags'
McapReader state (chunks, bio, data_start/data_end, as of rosbags 0.11): without it, rosbags
reads."""

from __future__ import annotations

import heapq
import mmap
import struct
from collections.abc import Iterator, Sequence
from itertools import pairwise
from operator import itemgetter
from typing import Any, BinaryIO

from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection
from rosbags.rosbag2.reader import DirectoryReader
from rosbags.rosbag2.storage_mcap import McapReader, decompress, msgsrc, read_exact

Message = tuple[Connection, int, bytes]  # connection, log time ns, CDR bytes
# a Message record after its opcode: record length, channel id, sequence, log time (MCAP spec)
_MESSAGE = struct.Struct("<QHIQ")
_HEAD = 31  # opcode, length and the fixed fields before a Message record's data
_NEEDED = ("chunks", "bio", "data_start", "data_end", "connections")


def messages(reader: AnyReader, conns: Sequence[Connection]) -> Iterator[Message] | None:
    """`reader.messages(connections=conns)` for a single uncompressed rosbag2 MCAP, faster;
    None for any other log (read it through rosbags)."""
    found = _storage(reader, conns)
    if found is None:
        return None
    storage, channels, bio = found
    if storage.chunks:
        return _indexed(storage, channels, bio)
    return _scanned(storage, channels, bio)


def _storage(reader: AnyReader, conns: Sequence[Connection]
             ) -> tuple[McapReader, dict[int, Connection], BinaryIO] | None:
    """The one MCAP storage behind `reader` and its channel ids mapped to `conns`, as rosbags'
    readers map them."""
    if len(reader.readers) != 1:
        return None
    outer = getattr(reader.readers[0], "storage", None)
    if isinstance(outer, McapReader):
        storage, channels = outer, {c.id: c for c in conns}
    elif (isinstance(outer, DirectoryReader) and len(outer.storages) == 1
          and isinstance(outer.storages[0], McapReader)
          and not outer.metadata.compression_mode):
        storage = outer.storages[0]
        channels = {x.id: match for x in storage.connections
                    if (match := _match(x, conns)) is not None}
    else:
        return None
    if not all(hasattr(storage, name) for name in _NEEDED) or storage.bio is None:
        return None
    return storage, channels, storage.bio


def _match(x: Connection, conns: Sequence[Connection]) -> Connection | None:
    """The connection of `conns` that a storage's connection `x` is (rosbags' rule)."""
    return next((y for y in conns if y.topic == x.topic and y.msgtype == x.msgtype
                 and y.ext == x.ext and (not x.digest or not y.digest or y.digest == x.digest)),
                None)


def _indexed(storage: McapReader, channels: dict[int, Connection], bio: BinaryIO
             ) -> Iterator[Message]:
    """The chunks' messages merged in time order, each chunk opened when its first message is
    due (McapReader.messages)."""
    infos = [x for x in storage.chunks if any(x.channel_count.get(cid, 0) for cid in channels)]
    if all(b.message_start_time >= a.message_end_time >= a.message_start_time
           for a, b in pairwise(infos)):
        yield from _in_turn(bio, infos, channels)
        return
    for t_ns, offset, conn, data in heapq.merge(*(_chunk(bio, x, channels) for x in infos)):
        if offset:
            yield conn, t_ns, data


def _in_turn(bio: BinaryIO, infos: list[Any], channels: dict[int, Connection]
             ) -> Iterator[Message]:
    """Chunks that follow each other in time (each starts at or after the end of the one
    before, as a recorder writes them), read in turn: the merge's order. Each is opened when
    the merge would open it, before the first message at or after its start time, so damage
    is met at the same message."""
    opened: dict[int, list[Message]] = {}
    due = 0  # the next chunk to open

    def open_until(t_ns: int) -> None:
        nonlocal due
        while due < len(infos) and infos[due].message_start_time <= t_ns:
            opened[due] = _chunk_messages(bio, infos[due], channels)
            due += 1

    for k, info in enumerate(infos):
        open_until(info.message_start_time)
        found = opened.pop(k)
        later = infos[k + 1].message_start_time if k + 1 < len(infos) else None
        if later is None or not found or found[-1][1] < later:
            yield from found
            continue
        for m in found:  # its last messages share their time with the next chunk's start
            if m[1] >= later:
                open_until(m[1])
            yield m


Entry = tuple[int, int, Any, Any]  # log time, chunk offset (0: the chunk's marker), conn, data


def _chunk(bio: BinaryIO, info: Any, channels: dict[int, Connection]) -> Iterator[Entry]:
    """One chunk's messages in time order, after a marker at its start time, for merging
    (rosbags' msgsrc)."""
    yield info.message_start_time, 0, None, None
    offset = info.chunk_start_offset
    for conn, t_ns, data in _chunk_messages(bio, info, channels):
        yield t_ns, offset, conn, data


def _chunk_messages(bio: BinaryIO, info: Any, channels: dict[int, Connection]
                    ) -> list[Message]:
    """One chunk's messages in time order (stable)."""
    start, stop = info.message_start_time, info.message_end_time + 1
    bio.seek(info.chunk_start_offset + 9 + 24)
    crc = int.from_bytes(read_exact(bio, 4), "little")
    bio.seek(info.chunk_start_offset + 9 + 40 + len(info.compression))
    raw = decompress(read_exact(bio, info.compressed_size), info.compression,
                     info.uncompressed_size, crc)
    found: list[Message] = []
    for cid, t_ns, data in _walk(raw, 0, len(raw)):
        if cid < 0:  # a record that does not hold together: rosbags says what
            return [(m.connection, m.timestamp, m.data)
                    for m in list(msgsrc(info, channels, start, stop, bio))[1:]
                    if m.connection is not None and m.data is not None]
        if start <= t_ns < stop and cid in channels:
            found.append((channels[cid], t_ns, data))
    found.sort(key=itemgetter(1))
    return found


def _walk(buf: bytes | mmap.mmap, pos: int, end: int) -> Iterator[tuple[int, int, Any]]:
    """(channel id, log time, data) of each Message record in buf[pos:end], in file order;
    (-1, position, None) for a record that overruns `end` (and then nothing more). Other
    records are skipped, a Chunk's as (-2, position, None)."""
    unpack = _MESSAGE.unpack_from
    while pos < end:
        if end - pos < _HEAD:
            if end - pos < 9 or buf[pos] == 0x05:
                yield -1, pos, None
                return
            size = int.from_bytes(buf[pos + 1:pos + 9], "little")
            cid, t_ns = -2 if buf[pos] == 0x06 else -3, 0
        else:
            size, cid, _, t_ns = unpack(buf, pos + 1)
            if buf[pos] != 0x05:
                cid = -2 if buf[pos] == 0x06 else -3
        nxt = pos + 9 + size
        if nxt > end or (cid >= 0 and size < 22):
            yield -1, pos, None
            return
        if cid >= 0:
            yield cid, t_ns, buf[pos + _HEAD:nxt]
        elif cid == -2:
            yield -2, pos, None
        pos = nxt


def _scanned(storage: McapReader, channels: dict[int, Connection], bio: BinaryIO
             ) -> Iterator[Message]:
    """An unindexed file's messages in file order (McapReader.messages_scan); out of time
    order, a chunk or a broken record: rosbags takes over where this stopped."""
    done = 0
    previous = -(2**63)
    with mmap.mmap(bio.fileno(), 0, access=mmap.ACCESS_READ) as buf:
        for cid, t_ns, data in _walk(buf, storage.data_start, storage.data_end):
            if cid < 0:
                break
            conn = channels.get(cid)
            if conn is None:
                continue
            if t_ns < previous:
                break
            previous = t_ns
            done += 1
            yield conn, t_ns, data
        else:
            return
    yield from _rosbags_after(storage, channels, done)


def _rosbags_after(storage: McapReader, channels: dict[int, Connection], done: int
                   ) -> Iterator[Message]:
    """rosbags' own reading (McapReader.messages), past the first `done` messages."""
    own = [x for x in storage.connections if x.id in channels]
    for k, (conn, t_ns, data) in enumerate(storage.messages(own)):
        if k >= done:
            yield channels[conn.id], t_ns, data
