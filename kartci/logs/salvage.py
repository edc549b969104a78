"""Read what is readable of a damaged log by streaming through it, without its index.

rosbags reads MCAP files and ROS 1 bags through their summary or index, which is written last:
a recording that was killed, a truncated download or one flipped byte in the index makes the
whole log unreadable, although most chunks are intact. Here the file is read front to back
instead (mcap's StreamReader for MCAP, a small record walker for ROS 1 bags, whose format is a
plain sequence of length-prefixed records), each chunk on its own: a damaged chunk is skipped,
and reading stops at the first record whose framing is broken, keeping everything before it.
A rosbag2 sqlite3 file is read row by row in id order up to the first damaged page and back
from its end down to it (rosbags reads it through the timestamp index, which damage breaks).

Only damaged logs come here, so everything readable is held in memory (raw bytes of the
messages, not decoded) and sorted by time once: simple, and in time order like rosbags.
"""

from __future__ import annotations

import bz2
import sqlite3
import struct
import sys
import zlib
from collections import Counter
from collections.abc import Iterator
from contextlib import closing, suppress
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any, BinaryIO

import lz4.frame  # type: ignore[import-untyped]
import yaml
from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Chunk, DataEnd, Message, Schema
from mcap.stream_reader import StreamReader
from rosbags.typesys.msg import normalize_msgtype

from kartci.logs.damage import count_of, describe
from kartci.logs.sqlitepages import Cell, table_rows

if sys.version_info >= (3, 14):  # pragma: no cover
    from compression import zstd
else:
    from backports import zstd

MCAP_MAGIC = b"\x89MCAP0\r\n"
ROS1_MAGIC = b"#ROSBAG V2.0\n"
_FORMATS = {"ros2msg": "msg", "ros2idl": "idl", "omgidl": "idl"}
_PAGES = "page by page, as sqlite's .recover does"


class NotStreamableError(Exception):
    """The file is not a format this module can stream (or not a log at all)."""


@dataclass(frozen=True)
class Conn:
    """One topic connection as found in the stream; `fmt` is "msg", "idl" or "" (none)."""

    topic: str
    msgtype: str
    fmt: str
    text: str
    ros1: bool


Key = tuple[int, int]  # (file number, connection or channel id)


@dataclass
class Salvage:
    """What streaming found: connections, raw messages (time, key, bytes), and problems;
    `how` the log was read, in words."""

    conns: dict[Key, Conn] = field(default_factory=dict)
    found: list[tuple[int, Key, bytes]] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    skipped_chunks: int = 0
    how: str = "by streaming without the index"

    def counts(self) -> Counter[Key]:
        return Counter(key for _, key, _ in self.found)

    def in_time_order(self) -> list[tuple[int, Key, bytes]]:
        return sorted(self.found, key=lambda m: m[0])


class _DamagedError(Exception):
    """A chunk or record does not hold together."""


# Bounds of the linear scan, so that a file that cannot be a log fails in a second instead of
# being walked to its end (a 20 GiB sparse file after the MCAP magic is 2e9 empty records):
MAX_RECORD_BYTES = 1 << 30  # one record (a chunk, an attachment); real chunks are a few MiB
MAX_UNKNOWN_RUN_BYTES = 16 << 20  # records of unknown type in a row; real logs have next to none
MAX_DB3_SALVAGE_BYTES = 2 << 30  # a damaged sqlite3 file is read whole into memory to salvage it


class _BoundedStreamReader(StreamReader):
    """mcap's StreamReader, failing on what no log holds: opcode 0x00 (the MCAP spec reserves
    it as invalid; zeros are what a sparse, preallocated or wiped file holds) and a long run of
    records of unknown type, which the plain reader skips without end."""

    def __init__(self, f: BinaryIO, size: int) -> None:
        super().__init__(f, emit_chunks=True, record_size_limit=min(size, MAX_RECORD_BYTES))
        self._unknown_run = 0

    def _read_record(self, opcode: int, length: int) -> Any:
        if opcode == 0:
            raise _DamagedError("opcode 0x00, which no MCAP record has: not an MCAP log from "
                                "here on")
        record = super()._read_record(opcode, length)
        self._unknown_run = self._unknown_run + 9 + length if record is None else 0
        if self._unknown_run > MAX_UNKNOWN_RUN_BYTES:
            raise _DamagedError(f"more than {MAX_UNKNOWN_RUN_BYTES >> 20} MiB of records of "
                                "unknown type in a row: not an MCAP log from here on")
        return record


KNOWN_COMPRESSIONS = ("", "none", "zstd", "lz4", "bz2")  # what a chunk may name


def _inflate(compression: str, data: bytes, size: int) -> bytes:
    """Decompress a chunk, never to more than its declared size (a damaged size or frame header
    must not make us allocate gigabytes)."""
    if compression in ("", "none"):
        raw = data
    elif compression == "zstd":
        raw = zstd.ZstdDecompressor().decompress(data, max_length=size + 1)
    elif compression == "lz4":
        raw = lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=size + 1)
    elif compression == "bz2":
        raw = bz2.BZ2Decompressor().decompress(data, max_length=size + 1)
    else:
        raise _DamagedError("a chunk names a compression that is not zstd, lz4, bz2 or none")
    if len(raw) != size:
        raise _DamagedError(f"a chunk decompresses to {len(raw)} bytes, not {size}")
    return bytes(raw)


# ---------------------------------------------------------------------------------------- MCAP


def _mcap_chunk_records(chunk: Any) -> Iterator[Any]:
    data = _inflate(chunk.compression, chunk.data, chunk.uncompressed_size)
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise _DamagedError("a chunk fails its CRC check")
    yield from _records(data, partial=False)


def _records(data: bytes, partial: bool) -> Iterator[Any]:
    """The schema, channel and message records in a chunk's bytes; `partial`: the bytes are the
    readable start of a cut chunk, and the record cut off ends the walk quietly."""
    stream = ReadDataStream(BytesIO(data))
    while stream.count < len(data):
        if partial and stream.count + 9 > len(data):
            return
        opcode, length = stream.read1(), stream.read8()
        end = stream.count + length
        if end > len(data):
            if partial:
                return
            raise _DamagedError("a record runs past the end of its chunk")
        if opcode == 0x03:
            yield Schema.read(stream)
        elif opcode == 0x04:
            yield Channel.read(stream)
        elif opcode == 0x05:
            if length < 22:
                raise _DamagedError("a message record is too short")
            yield Message.read(stream, length)
        if stream.count > end:
            raise _DamagedError("a record's fields run past its length")
        stream.read(end - stream.count)


_CHUNK_HEAD = struct.Struct("<BQQQQII")  # opcode, length, start, end, size, crc, name length


def _stream_inflate(compression: str, data: bytes, size: int) -> bytes:
    """As much of a cut chunk as decompresses: zstd and lz4 frames give up their blocks as
    they arrive (stream decompression), so every whole block before the cut is recovered."""
    if compression in ("", "none"):
        return data[:size]
    if compression == "zstd":
        return bytes(zstd.ZstdDecompressor().decompress(data, max_length=size))
    if compression == "lz4":
        return bytes(lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=size))
    raise _DamagedError("a chunk names a compression stream decompression cannot read (not "
                        "zstd, lz4 or none)")


def _cut_chunk(f: BinaryIO, at: int, size: int, state: _McapState) -> str | None:
    """The messages of a chunk record starting at byte `at` that the file's end cuts off,
    by stream decompression; None when no chunk starts there. Returns what was lost, in
    words (messages estimated from the chunk's size and the recovered messages' mean)."""
    f.seek(at)
    head = f.read(_CHUNK_HEAD.size)
    if len(head) < _CHUNK_HEAD.size or head[0] != 0x06:
        return None
    _, _, _, _, full, _, name_len = _CHUNK_HEAD.unpack(head)
    compression = f.read(min(name_len, 16)).decode("ascii", errors="replace")
    f.seek(8, 1)  # the records' compressed length: the file ends before it
    before = len(state.into.found)
    try:
        raw = _stream_inflate(compression, f.read(max(0, min(size - f.tell(),
                                                             MAX_RECORD_BYTES))), full)
        for rec in _records(raw, partial=True):
            state.take(rec)
    except Exception:  # a damaged frame raises anything: keep what came before it
        pass
    got = len(state.into.found) - before
    used = sum(len(d) + 31 for _, _, d in state.into.found[before:])  # message records' bytes
    where = f"the file ends inside a chunk at byte {size}"
    if got == 0:
        shown = (compression or "uncompressed") if compression in KNOWN_COMPRESSIONS else (
            "an unknown compression")  # a damaged name is bytes of the file: never quoted
        return (f"{where} ({shown}, {full} bytes unpacked): none of "
                "its messages could be recovered (the cut falls in its first block)")
    lost = round(max(0, full - used) / (used / got))
    return (f"{where}: {count_of(got, 'message')} recovered from it by stream "
            f"decompression, about {count_of(lost, 'message')} lost with its rest")


@dataclass
class _McapState:
    part: int
    into: Salvage
    schemas: dict[int, tuple[str, str, str]] = field(default_factory=dict)
    foreign: set[str] = field(default_factory=set)

    def take(self, rec: Any) -> None:
        if isinstance(rec, Schema):
            text = rec.data.decode("utf-8", errors="replace")
            self.schemas[rec.id] = (rec.name, _FORMATS.get(rec.encoding, ""), text)
        elif isinstance(rec, Channel):
            name, fmt, text = self.schemas.get(rec.schema_id, ("", "", ""))
            if rec.message_encoding == "cdr" and name:
                self.into.conns.setdefault((self.part, rec.id),
                                           Conn(rec.topic, name, fmt, text, ros1=False))
            else:
                self.foreign.add(rec.topic)
        elif isinstance(rec, Message):
            self.into.found.append((rec.log_time, (self.part, rec.channel_id), rec.data))
        elif isinstance(rec, Chunk):
            self.chunk(rec)

    def chunk(self, rec: Any) -> None:
        try:
            for inner in _mcap_chunk_records(rec):
                self.take(inner)
        except Exception:  # a damaged chunk raises anything; keep the rest
            self.into.skipped_chunks += 1


def read_mcap(path: Path, part: int, into: Salvage) -> None:
    """Stream one MCAP file into `into`; chunks are checked (CRC, size) and unpacked here."""
    size = path.stat().st_size
    with path.open("rb") as f:
        if f.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise NotStreamableError("does not start with the MCAP magic bytes")
        f.seek(0)
        state = _McapState(part, into)
        records = _BoundedStreamReader(f, size).records
        data_ended = False
        while True:
            at = f.tell()  # the stream reads exactly: here the next record starts
            try:
                rec = next(records)
            except StopIteration:
                break
            except Exception as err:  # damaged framing raises anything
                stopped = _stopped(f, size, err, data_ended, "summary")
                cut = None if data_ended else _cut_chunk(f, at, size, state)
                into.problems.append(cut or stopped)
                break
            data_ended = data_ended or isinstance(rec, DataEnd)
            state.take(rec)
    if state.foreign:
        into.problems.append(f"left out {count_of(len(state.foreign), 'topic')} not in CDR with "
                             f"a ROS 2 schema ({', '.join(sorted(state.foreign)[:3])})")


def _stopped(f: BinaryIO, size: int, err: Exception, complete: bool, tail: str) -> str:
    why = str(err) if isinstance(err, _DamagedError) else describe(err)
    if complete:
        return f"its {tail} is damaged ({why}), all data before it was read"
    return f"reading stopped at byte {f.tell()} of {size}: {why}"


# ------------------------------------------------------------------------------------ ROS 1 bag


def _fields(header: bytes) -> dict[str, bytes]:
    fields: dict[str, bytes] = {}
    pos = 0
    while pos < len(header):
        if pos + 4 > len(header):
            raise _DamagedError("a record header ends in the middle of a field")
        (n,) = struct.unpack_from("<I", header, pos)
        item = header[pos + 4: pos + 4 + n]
        if len(item) != n or b"=" not in item:
            raise _DamagedError("a record header field is malformed")
        name, value = item.split(b"=", 1)
        fields[name.decode("ascii", errors="replace")] = value
        pos += 4 + n
    return fields


def _ros1_record(src: BinaryIO, limit: int) -> tuple[dict[str, bytes], int]:
    """Read one record's header and return it with its data length (data not read yet)."""
    fields = _fields(_sized(src, limit))
    (length,) = struct.unpack("<I", _exact(src, 4))
    if src.tell() + length > limit:
        raise _DamagedError("a record's data runs past the end of the file")
    if "op" not in fields or len(fields["op"]) != 1:
        raise _DamagedError("a record has no op field")
    return fields, length


def _exact(src: BinaryIO, n: int) -> bytes:
    data = src.read(n)
    if len(data) != n:
        raise _DamagedError("the file ends in the middle of a record (truncated)")
    return data


def _sized(src: BinaryIO, limit: int) -> bytes:
    (n,) = struct.unpack("<I", _exact(src, 4))
    if src.tell() + n > limit:
        raise _DamagedError("a record header runs past the end of the file")
    return _exact(src, n)


def _u32(fields: dict[str, bytes], name: str) -> int:
    value = fields.get(name, b"")
    if len(value) != 4:
        raise _DamagedError(f"a record's {name} field is malformed")
    return int(struct.unpack("<I", value)[0])


def _topic(raw: bytes) -> str:
    name = raw.decode("utf-8")
    return ("/" if name.startswith("/") else "") + "/".join(x for x in name.split("/") if x)


@dataclass
class _Ros1State:
    part: int
    into: Salvage

    def take(self, op: int, fields: dict[str, bytes], data: bytes) -> None:
        if op == 0x02:
            time = fields.get("time", b"")
            if len(time) != 8:
                raise _DamagedError("a message record's time is malformed")
            sec, nsec = struct.unpack("<II", time)
            self.into.found.append((sec * 1_000_000_000 + nsec,
                                    (self.part, _u32(fields, "conn")), data))
        elif op == 0x07:
            key = (self.part, _u32(fields, "conn"))
            if key not in self.into.conns:
                self.into.conns[key] = self.connection(fields, _fields(data))

    @staticmethod
    def connection(fields: dict[str, bytes], info: dict[str, bytes]) -> Conn:
        text = info.get("message_definition", b"").decode("utf-8", errors="replace")
        msgtype = normalize_msgtype(info["type"].decode("utf-8"))
        return Conn(_topic(fields["topic"]), msgtype, "msg" if text else "", text, ros1=True)

    def chunk(self, fields: dict[str, bytes], data: bytes) -> None:
        try:
            compression = fields.get("compression", b"").decode("ascii")
            raw = _inflate(compression, data, _u32(fields, "size"))
            src = BytesIO(raw)
            while src.tell() < len(raw):
                inner, length = _ros1_record(src, len(raw))
                self.take(inner["op"][0], inner, _exact(src, length))
        except Exception:  # a damaged chunk raises anything; keep the rest
            self.into.skipped_chunks += 1


def read_ros1(path: Path, part: int, into: Salvage) -> None:
    """Walk a ROS 1 bag (format 2.0) record by record, chunks included, ignoring its index."""
    size = path.stat().st_size
    with path.open("rb") as f:
        if f.readline(64) != ROS1_MAGIC:
            raise NotStreamableError("does not start with '#ROSBAG V2.0'")
        state = _Ros1State(part, into)
        index_pos = 0
        while f.tell() < size:
            start = f.tell()
            try:
                fields, length = _ros1_record(f, size)
                op = fields["op"][0]
                if op == 0x03:
                    index_pos = struct.unpack("<Q", fields.get("index_pos", bytes(8)))[0]
                if op == 0x05:
                    state.chunk(fields, _exact(f, length))
                elif op in (0x02, 0x07):
                    state.take(op, fields, _exact(f, length))
                else:
                    f.seek(length, 1)
            except Exception as err:  # damaged framing raises anything
                into.problems.append(_stopped(f, size, err, 0 < index_pos <= start, "index"))
                return


def _db3_image(path: Path) -> bytes:
    """The whole file, to salvage in memory; an OSError when it is larger than
    MAX_DB3_SALVAGE_BYTES (a sparse 20 GiB file would be read, then walked page by page)."""
    size = path.stat().st_size
    if size > MAX_DB3_SALVAGE_BYTES:
        raise OSError(f"{size:,} bytes, more than the {MAX_DB3_SALVAGE_BYTES >> 30} GiB a "
                      "damaged sqlite3 file is read into memory to salvage")
    return path.read_bytes()


def _db3_connect(path: Path) -> sqlite3.Connection:
    """`path`'s whole pages, in memory (the file is not touched): a page cut short by a
    truncation would read as zeros past the cut, inside messages that look whole. With
    `writable_schema` sqlite opens an image shorter than its header says (nothing is
    written: it only skips that check) and reads the pages there are."""
    data = _db3_image(path)
    size = int.from_bytes(data[16:18], "big")
    size = 65536 if size == 1 else size
    if size < 512 or size & (size - 1):
        raise sqlite3.DatabaseError("its header names no valid page size")
    if len(data) < size:  # sqlite's deserialize takes an empty image for a MemoryError
        raise sqlite3.DatabaseError("it is shorter than one page")
    con = sqlite3.connect(":memory:")
    try:
        con.deserialize(data[:len(data) // size * size])
        con.execute("PRAGMA writable_schema=ON")
    except BaseException:
        con.close()
        raise
    return con


def _db3_topics(con: sqlite3.Connection, part: int, into: Salvage) -> None:
    """The topics table (and the message definitions, where the file has them) as Conns."""
    defs: dict[str, tuple[str, str]] = {}
    with suppress(sqlite3.Error):  # older rosbag2 files have no message_definitions table
        for msgtype, encoding, text in con.execute(
                "SELECT topic_type, encoding, encoded_message_definition "
                "FROM message_definitions"):
            if isinstance(msgtype, str) and isinstance(text, str):
                defs[msgtype] = (_FORMATS.get(encoding, ""), text)
    for tid, name, msgtype in con.execute("SELECT id, name, type FROM topics"):
        if isinstance(name, str) and isinstance(msgtype, str):  # a damaged page reads as NULLs
            fmt, text = defs.get(msgtype, ("", ""))
            into.conns[part, tid] = Conn(name, msgtype, fmt, text, ros1=False)


def _db3_rows(con: sqlite3.Connection, part: int, into: Salvage) -> str | None:
    """Every message row sqlite can still reach, in id order up to the first damaged page,
    then back from the last row down to the damage; None when nothing was damaged, else
    where reading stopped."""
    query = "SELECT id, topic_id, timestamp, data FROM messages WHERE id > ? ORDER BY id"
    last = 0
    try:
        for rid, tid, t_ns, data in con.execute(query, (last,)):
            if _db3_row(t_ns, (part, tid), data, into):
                last = rid
    except sqlite3.Error:
        pass
    else:
        return None
    with suppress(sqlite3.Error):  # the rows after the damage, read from the end
        for _, tid, t_ns, data in con.execute(query + " DESC", (last,)):
            _db3_row(t_ns, (part, tid), data, into)
    return f"damaged after message row {last}" if last else "damaged before its first message row"


def _db3_row(t_ns: object, key: Key, data: object, into: Salvage) -> bool:
    """Keep one message row; False for what damage makes sqlite return instead (a page cut
    short reads as rows of NULLs)."""
    if not isinstance(t_ns, int) or not isinstance(data, bytes):
        return False
    into.found.append((t_ns, key, data))
    return True


def _listed(path: Path) -> int | None:
    """How many messages rosbag2's metadata.yaml says the file holds (None: not said)."""
    with suppress(OSError, ValueError, LookupError, yaml.YAMLError, AttributeError, TypeError):
        with (path.parent / "metadata.yaml").open(encoding="utf-8") as f:
            doc = yaml.safe_load(f.read(1_000_000))
        for entry in doc["rosbag2_bagfile_information"].get("files") or []:
            if entry.get("path") == path.name:
                return int(entry["message_count"])
    return None


def _db3_sql(path: Path, part: int, into: Salvage) -> str | None:
    """What sqlite can still read of a rosbag2 sqlite3 file: its topics and every message row
    before and after the damage. None when it read cleanly, else why it stopped, in words."""
    try:
        con = _db3_connect(path)
    except (sqlite3.Error, OSError) as err:
        return f"does not open ({describe(err)})"
    with closing(con):
        try:
            _db3_topics(con, part, into)
        except sqlite3.Error as err:
            return f"has an unreadable topics table ({describe(err)})"
        stopped = _db3_rows(con, part, into)
    listed = _listed(path)
    if stopped is None and (listed is None or len(into.found) >= listed):
        return None
    return stopped or "is damaged (its message table ends early)"


def _is_message(types: tuple[int, ...]) -> bool:
    """A row shaped as rosbag2's messages: (id, topic_id, timestamp: integers, data: blob)."""
    ints = [1 <= t <= 6 or t in (8, 9) for t in types]
    return len(types) == 4 and ints[1] and ints[2] and types[3] >= 12 and types[3] % 2 == 0


def _texts(types: tuple[int, ...]) -> bool:
    """A row shaped as rosbag2's topics or message definitions: (id, text, text, ...)."""
    return len(types) > 1 and types[0] == 0 and all(t >= 13 and t % 2 for t in types[1:])


@dataclass
class _Db3Pages:
    """The rows of rosbag2's tables found in the leaf pages, told apart by their shape:
    messages (id, topic_id, timestamp, data), topics (id, name starting with "/", type,
    serialization format[, QoS[, type hash]]) and message_definitions (id, type, encoding,
    text, hash); `broken` counts message rows whose overflow chain is broken."""

    topics: dict[int, tuple[str, str]] = field(default_factory=dict)
    defs: dict[str, tuple[str, str]] = field(default_factory=dict)
    messages: dict[int, tuple[int, int, bytes]] = field(default_factory=dict)
    broken: set[int] = field(default_factory=set)

    def take(self, cell: Cell) -> None:
        types, values = cell.types, cell.values
        if _is_message(types):
            if values is None:
                self.broken.add(cell.rowid)
            elif (isinstance(t_ns := values[2], int) and isinstance(tid := values[1], int)
                  and isinstance(raw := values[3], bytes)):
                self.messages.setdefault(cell.rowid, (t_ns, tid, raw))
        elif values is None or not _texts(types):
            return
        elif 4 <= len(types) <= 6 and str(values[1]).startswith("/"):
            self.topics.setdefault(cell.rowid, (str(values[1]), str(values[2])))
        elif len(types) == 5:
            self.defs.setdefault(str(values[1]), (_FORMATS.get(str(values[2]), ""),
                                                  str(values[3])))


def _db3_pages(path: Path, part: int, into: Salvage) -> tuple[int, str]:
    """The message rows of a rosbag2 sqlite3 file's intact leaf pages whose topic row was
    found too, in time then id order, as rosbags reads them; (how many rows were found, in
    all, what was lost beyond the metadata.yaml count, in words)."""
    data = _db3_image(path)
    found = _Db3Pages()
    for cell in table_rows(data[:len(data) // 512 * 512]):
        found.take(cell)
    for tid, (name, msgtype) in found.topics.items():
        fmt, text = found.defs.get(msgtype, ("", ""))
        into.conns[part, tid] = Conn(name, msgtype, fmt, text, ros1=False)
    orphans = 0
    for _, (t_ns, tid, raw) in sorted(found.messages.items(), key=lambda m: (m[1][0], m[0])):
        if tid in found.topics:
            into.found.append((t_ns, (part, tid), raw))
        else:
            orphans += 1
    broken = len(found.broken - found.messages.keys())
    why = [f"{count_of(broken, 'row')} with a broken overflow chain"] if broken else []
    if orphans:
        why.append(f"{count_of(orphans, 'row')} of a topic whose row is lost")
    return len(found.messages) + broken, ", ".join(why)


def read_db3(path: Path, part: int, into: Salvage) -> None:
    """A rosbag2 sqlite3 file through sqlite; when that stops early, page by page (as sqlite's
    `.recover` does) if that finds more. What was lost (against metadata.yaml's count) is
    among the problems."""
    into.how = _PAGES if into.how == _PAGES else "row by row from its sqlite tables"
    rows = Salvage()
    stopped = _db3_sql(path, part, rows)
    how, lost = "read", ""
    if stopped is not None:
        pages, seen = Salvage(), 0
        with suppress(OSError):
            seen, lost = _db3_pages(path, part, pages)
        if len(pages.found) > len(rows.found) or (seen and not rows.found):
            rows, how, into.how = pages, "read page by page", _PAGES
    into.conns.update(rows.conns)
    into.found.extend(rows.found)
    if stopped is None:
        return
    got, listed = len(rows.found), _listed(path)
    total = ("an unknown number lost (no count in metadata.yaml)" if listed is None
             else f"{count_of(max(listed - got, 0), 'message')} of {listed} lost")
    lost = f" ({lost})" if lost and how != "read" else ""
    into.problems.append(f"{path.name} {stopped}: {count_of(got, 'message')} {how}, {total}{lost}")


def salvage(path: Path) -> Salvage:
    """Stream `path` (a .bag, an .mcap, a .db3 or a folder of .mcap or .db3 files);
    NotStreamableError if it is none of these."""
    into = Salvage()
    if path.is_dir():
        parts = sorted(path.glob("*.mcap"))
        readers = [read_mcap] * len(parts)
        if not parts:
            parts = sorted(path.glob("*.db3"))
            readers = [read_db3] * len(parts)
        if not parts:
            raise NotStreamableError("holds no .mcap or .db3 files to read without the index")
        for number, (part, read) in enumerate(zip(parts, readers, strict=True)):
            read(part, number, into)
    elif path.suffix == ".bag":
        read_ros1(path, 0, into)
    elif path.suffix == ".db3":
        read_db3(path, 0, into)
    else:
        read_mcap(path, 0, into)
    return into
