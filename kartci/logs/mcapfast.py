"""The raw messages of a rosbag2 MCAP (a folder with one .mcap file, or a bare .mcap) as rosbags
reads them, in its order, without its per-message layers: each record is taken apart with one
struct call over the chunk's (or the mapped file's) bytes instead of a BytesIO and three reads
per message, and no generator per layer (AnyReader, the rosbag2 reader, the storage).

The file is read by the MCAP specification alone: its footer, its summary through mcap's own
reader (`mcap.reader`: channels, schemas, chunk indexes), its records with `struct`. Which
chunks hold a channel is worked out from the chunk index's message index offsets as rosbags
works it out, so the same chunks are read in the same order. A summary whose CRC does not match,
or a record that does not hold together, is left to rosbags: its public reader
(`AnyReader.messages`) is started over and the messages already returned are skipped, so it
fails where and how it always did (and kartci.logs.reader salvages the rest as before). Logs of
any other kind (ROS 1, sqlite3, several files, compression per file or message, a rosbag2 folder
without a summary) are read by rosbags alone."""

from __future__ import annotations

import heapq
import mmap
import struct
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from itertools import pairwise
from operator import itemgetter
from pathlib import Path, PurePath
from typing import Any, BinaryIO

import lz4.frame  # type: ignore[import-untyped]
import yaml
import zstandard
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Channel as McapChannel
from mcap.records import ChunkIndex
from mcap.summary import Summary
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection
from rosbags.rosbag2 import Reader as Rosbag2Reader

from kartci.errors import LogError

Message = tuple[Connection, int, bytes]  # connection, log time ns, CDR bytes
# a Message record after its opcode: record length, channel id, sequence, log time (MCAP spec)
_MESSAGE = struct.Struct("<QHIQ")
_HEAD = 31  # opcode, length and the fixed fields before a Message record's data
_MAGIC = b"\x89MCAP0\r\n"
_FOOTER = struct.Struct("<BQQQI")  # opcode 0x02, length 20, summary start, summary offsets, crc
_FOOTER_SIZE = _FOOTER.size + len(_MAGIC)
_CHUNK_FIELDS = 9 + 24  # a Chunk record's opcode and length, then start, end, uncompressed size
_DECOMPRESS: dict[str, Callable[[bytes, int], bytes]] = {
    "": lambda data, _size: data,
    "zstd": lambda data, size: zstandard.ZstdDecompressor().decompress(data, max_output_size=size),
    "lz4": lambda data, _size: bytes(lz4.frame.decompress(data)),
}


class _DamagedError(LogError):
    """A record that does not hold together: rosbags reads from here (never leaves this
    module)."""


@dataclass(frozen=True)
class _Chunk:
    """What the summary's chunk index says of one chunk."""

    message_start_time: int
    message_end_time: int
    chunk_start_offset: int
    compression: str
    compressed_size: int
    uncompressed_size: int
    counts: dict[int, int]  # channel id -> messages, as rosbags computes it from the index


@dataclass(frozen=True)
class _Layout:
    """Where one MCAP file's messages are, and which of its channels are wanted."""

    path: Path
    channels: dict[int, Connection]
    data_start: int
    data_end: int
    chunks: list[_Chunk]  # empty: read the data section in file order


def messages(reader: AnyReader, conns: Sequence[Connection]) -> Iterator[Message] | None:
    """`reader.messages(connections=conns)` for a single rosbag2 MCAP, faster; None for any
    other log (read it through rosbags)."""
    try:
        layout = _layout(reader, conns)
    except (OSError, ValueError, KeyError, TypeError, struct.error, McapError, yaml.YAMLError):
        return None  # rosbags opened it: let it say what it makes of this
    if layout is None:
        return None
    return _guarded(reader, conns, layout)


def _guarded(reader: AnyReader, conns: Sequence[Connection], layout: _Layout
             ) -> Iterator[Message]:
    done = 0
    try:
        with layout.path.open("rb") as bio:
            found = _indexed(layout, bio) if layout.chunks else _scanned(layout, bio)
            for message in found:
                yield message
                done += 1
    except _DamagedError:
        for k, message in enumerate(reader.messages(connections=conns)):
            if k >= done:
                yield message


def _layout(reader: AnyReader, conns: Sequence[Connection]) -> _Layout | None:
    """The one MCAP file behind `reader`, its data section, its chunks and its channel ids
    mapped to `conns` (rosbags' rule: topic, type and serialization format)."""
    if len(reader.readers) != 1 or not isinstance(reader.readers[0], Rosbag2Reader):
        return None
    bag = reader.readers[0]
    if bag.compression_mode:
        return None
    where = Path(str(bag.path))
    bare = where.is_file()
    path = where if bare else _only_mcap(where)
    if path is None or path.suffix != ".mcap":
        return None
    with path.open("rb") as bio:
        bio.seek(len(_MAGIC) + 1)
        header_size = int.from_bytes(bio.read(8), "little")
        data_start = len(_MAGIC) + 9 + header_size
        bio.seek(-_FOOTER_SIZE, 2)
        footer_start = bio.tell()
        footer = bio.read(_FOOTER.size)
        _, _, summary_start, _, crc = _FOOTER.unpack(footer)
        if not summary_start:
            if not bare:  # the folder's connections are matched through the summary
                return None
            return _Layout(path, {c.id: c for c in conns}, data_start, footer_start, [])
        bio.seek(summary_start)
        summary_bytes = bio.read(footer_start - summary_start)
        if crc and zlib.crc32(footer[:-4], zlib.crc32(summary_bytes)) != crc:
            return None
        bio.seek(0)
        summary = make_reader(bio).get_summary()
    if summary is None:
        return None
    channels = {c.id: c for c in conns} if bare else _channels(summary, conns)
    chunks = [_chunk_info(x) for x in summary.chunk_indexes]
    return _Layout(path, channels, data_start, summary_start, chunks)


def _channels(summary: Summary, conns: Sequence[Connection]) -> dict[int, Connection]:
    """A rosbag2 folder's connections by the channel id of its MCAP file."""
    channels = {}
    for cid, channel in summary.channels.items():
        schema = summary.schemas.get(channel.schema_id)
        match = _match(channel, "__schemaless__" if schema is None else schema.name, conns)
        if match is not None:
            channels[cid] = match
    return channels


def _only_mcap(folder: Path) -> Path | None:
    """The one storage file of a rosbag2 folder that is stored as MCAP, from its metadata.yaml."""
    info = yaml.safe_load((folder / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    files = info.get("relative_file_paths") or []
    if info.get("storage_identifier") != "mcap" or len(files) != 1:
        return None
    return folder / PurePath(files[0]).name


def _match(channel: McapChannel, msgtype: str, conns: Sequence[Connection]
           ) -> Connection | None:
    """The connection of `conns` that a file's channel is; None when none is, or several."""
    found = [c for c in conns if c.topic == channel.topic and c.msgtype == msgtype
             and getattr(c.ext, "serialization_format", None) == channel.message_encoding]
    return found[0] if len(found) == 1 else None


def _chunk_info(x: ChunkIndex) -> _Chunk:
    """A chunk index with each channel's message count as rosbags reads it: the length of the
    channel's message index (15 bytes of header, 16 per message)."""
    by_offset = sorted((offset, cid) for cid, offset in x.message_index_offsets.items())
    ends = [*(o for o, _ in by_offset),
            x.chunk_start_offset + x.chunk_length + x.message_index_length]
    counts = {cid: count // 16 for (start, cid), end in zip(by_offset, ends[1:], strict=False)
              if (count := end - start - 15)}
    return _Chunk(x.message_start_time, x.message_end_time, x.chunk_start_offset,
                  x.compression, x.compressed_size, x.uncompressed_size, counts)


def _indexed(layout: _Layout, bio: BinaryIO) -> Iterator[Message]:
    """The chunks' messages merged in time order, each chunk opened when its first message is
    due (as rosbags' McapReader.messages)."""
    channels = layout.channels
    infos = [x for x in layout.chunks if any(x.counts.get(cid, 0) for cid in channels)]
    if all(b.message_start_time >= a.message_end_time >= a.message_start_time
           for a, b in pairwise(infos)):
        yield from _in_turn(bio, infos, channels)
        return
    for t_ns, offset, conn, data in heapq.merge(*(_chunk(bio, x, channels) for x in infos)):
        if offset:
            yield conn, t_ns, data


def _in_turn(bio: BinaryIO, infos: list[_Chunk], channels: dict[int, Connection]
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


def _chunk(bio: BinaryIO, info: _Chunk, channels: dict[int, Connection]) -> Iterator[Entry]:
    """One chunk's messages in time order, after a marker at its start time, for merging
    (as rosbags' msgsrc)."""
    yield info.message_start_time, 0, None, None
    offset = info.chunk_start_offset
    for conn, t_ns, data in _chunk_messages(bio, info, channels):
        yield t_ns, offset, conn, data


def _chunk_messages(bio: BinaryIO, info: _Chunk, channels: dict[int, Connection]
                    ) -> list[Message]:
    """One chunk's messages in time order (stable)."""
    start, stop = info.message_start_time, info.message_end_time + 1
    raw = _decompressed(bio, info)
    found: list[Message] = []
    for cid, t_ns, data in _walk(raw, 0, len(raw)):
        if cid < 0:
            raise _DamagedError
        if start <= t_ns < stop and cid in channels:
            found.append((channels[cid], t_ns, data))
    found.sort(key=itemgetter(1))
    return found


def _decompressed(bio: BinaryIO, info: _Chunk) -> bytes:
    """A chunk's records: read, decompressed and checked against its size and CRC (MCAP spec:
    the CRC of the uncompressed records, 0 for none)."""
    bio.seek(info.chunk_start_offset + _CHUNK_FIELDS)
    crc = int.from_bytes(bio.read(4), "little")
    bio.seek(info.chunk_start_offset + _CHUNK_FIELDS + 16 + len(info.compression))
    data = bio.read(info.compressed_size)
    unpack = _DECOMPRESS.get(info.compression)
    if unpack is None or len(data) != info.compressed_size:
        raise _DamagedError
    try:
        raw = unpack(data, info.uncompressed_size)
    except (RuntimeError, ValueError, zstandard.ZstdError) as err:  # lz4: RuntimeError
        raise _DamagedError from err
    if len(raw) != info.uncompressed_size or (crc and zlib.crc32(raw) != crc):
        raise _DamagedError
    return raw


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


def _scanned(layout: _Layout, bio: BinaryIO) -> Iterator[Message]:
    """An unindexed file's messages in file order (as rosbags' McapReader.messages_scan); out
    of time order, a chunk or a broken record: rosbags takes over where this stopped."""
    previous = -(2**63)
    with mmap.mmap(bio.fileno(), 0, access=mmap.ACCESS_READ) as buf:
        for cid, t_ns, data in _walk(buf, layout.data_start, layout.data_end):
            if cid < 0:
                break
            conn = layout.channels.get(cid)
            if conn is None:
                continue
            if t_ns < previous:
                break
            previous = t_ns
            yield conn, t_ns, data
        else:
            return
    raise _DamagedError
