"""Write a run log: one MCAP file, ROS 2 profile, CDR messages with embedded ros2msg schemas."""

from __future__ import annotations

import os
import struct
import tempfile
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

from mcap.records import MessageIndex
from mcap.writer import CompressionType, Writer
from rosbags.typesys.store import Typestore

from kartci.atomic import check_target
from kartci.logs.cdr import Serialise, compile_fixed
from kartci.logs.qos import offered_qos_profiles
from kartci.logs.types import typestore

# one MCAP Message record's head: opcode 0x05, record length, channel id, sequence, log time,
# publish time (the MCAP spec's Message record, little-endian)
_MESSAGE = struct.Struct("<BQHIQQ")
_MESSAGE_OPCODE = 0x05
_MESSAGE_HEAD = 22  # bytes of a Message record before its data
_RECORD_HEAD = 9 + _MESSAGE_HEAD  # with the opcode and the record length
BATCH = 512  # messages held before they go into the chunk together
LAYOUTS = 4  # fixed CDR layouts kept per topic (/tf alternates between two)
Pending = tuple[int, int, int, bytes | memoryview]  # channel id, sequence, t ns, CDR data


class _Chunks:
    """Appends Message records to an `mcap.writer.Writer`'s open chunk in batches: the same
    bookkeeping as its `add_message` (statistics, the chunk's message index, a chunk closed
    as soon as it outgrows the chunk size), one `struct` call and one write per record in
    place of its five writes and two seeks. The writer's state is private to it, so this holds
    it only when mcap is the version it was written against (tests/logs/test_writer.py checks
    the bytes against `add_message`); otherwise every record goes through `add_message`."""

    def __init__(self, writer: Writer) -> None:
        """Find the writer's chunk builder and statistics, or fall back."""
        names = ("_Writer__chunk_builder", "_Writer__statistics", "_Writer__chunk_size",
                 "_Writer__finalize_chunk")
        found = all(hasattr(writer, n) for n in names)
        self.writer = writer
        self.builder = writer._Writer__chunk_builder if found else None  # type: ignore[attr-defined]
        self.stats = writer._Writer__statistics if found else None  # type: ignore[attr-defined]
        self.chunk_size: int = writer._Writer__chunk_size if found else 0  # type: ignore[attr-defined]

    def add(self, batch: list[Pending]) -> None:
        """Append the batch's messages, in order: each run of them that fits the open chunk
        in one write, the statistics brought up to date once per run."""
        cb, st = self.builder, self.stats
        if cb is None or st is None:
            for cid, seq, t, data in batch:
                self.writer.add_message(cid, log_time=t, data=bytes(data), publish_time=t,
                                        sequence=seq)
            return
        i = 0
        while i < len(batch):
            j, full = self._fill(cb, batch, i)
            self._count(cb, st, batch[i:j])
            i = j
            if full:
                self.writer._Writer__finalize_chunk()  # type: ignore[attr-defined]

    def _fill(self, cb: Any, batch: list[Pending], i: int) -> tuple[int, bool]:
        """Write batch[i:j] into the open chunk, j where the chunk outgrew the chunk size (or
        the batch's end); whether it did."""
        out = cb.record_writer._buffer  # a new one after each chunk
        indices, pack, limit = cb.message_indices, _MESSAGE.pack, self.chunk_size
        pos = out.tell()
        parts: list[bytes | memoryview] = []
        for j in range(i, len(batch)):
            cid, seq, t, data = batch[j]
            index = indices.get(cid)
            if index is None:
                index = indices[cid] = MessageIndex(channel_id=cid, records=[])
            index.records.append((t, pos))
            parts += (pack(_MESSAGE_OPCODE, _MESSAGE_HEAD + len(data), cid, seq, t, t), data)
            pos += _RECORD_HEAD + len(data)
            if pos > limit:
                out.write(b"".join(parts))
                return j + 1, True
        out.write(b"".join(parts))
        return len(batch), False

    @staticmethod
    def _count(cb: Any, st: Any, run: list[Pending]) -> None:
        """The statistics and the chunk's time range after `run`, as add_message keeps them
        one message at a time."""
        times = [t for _, _, t, _ in run]
        first, last = min(times), max(times)
        st.message_start_time = first if st.message_count == 0 else min(first,
                                                                         st.message_start_time)
        st.message_end_time = max(last, st.message_end_time)
        st.message_count += len(run)
        counts = st.channel_message_counts
        for cid, _, _, _ in run:
            counts[cid] += 1
        cb.message_start_time = first if cb.num_messages == 0 else min(cb.message_start_time,
                                                                       first)
        cb.message_end_time = max(cb.message_end_time, last)
        cb.num_messages += len(run)


class McapLogWriter:
    """Writes to a `.<name>.<unique>.partial` file beside `path` and renames it on a clean
    close, so a failed run never leaves a truncated log in place of a good one, two writers of
    one path never share a partial file, and a failed write (a full disk) leaves no partial
    file behind to fill the disk for the runs after it. `store` holds the types
    to write (default kartci's); extract passes one that also has the types only its source log
    defines."""

    def __init__(self, path: Path, store: Typestore | None = None) -> None:
        self.path = path
        self.store = store if store is not None else typestore()
        check_target(path)  # a device, FIFO or symlink at `path` is refused, never replaced
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".partial")
        self._tmp = Path(tmp)
        self._file: BinaryIO = os.fdopen(fd, "wb")
        try:
            self._writer = Writer(self._file, compression=CompressionType.ZSTD)
            self._writer.start(profile="ros2", library="kartci")
        except BaseException:
            self._discard()
            raise
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._seq: dict[int, int] = {}
        self._chunks = _Chunks(self._writer)
        self._pending: list[Pending] = []
        self._layouts: dict[int, list[Serialise]] = {}  # per channel (see kartci.logs.cdr)

    def _channel(self, topic: str, typename: str, latched: bool) -> int:
        cid = self._channels.get(topic)
        if cid is None:
            self._flush()  # a channel's record goes into the chunk after the messages before it
            sid = self._schemas.get(typename)
            if sid is None:
                text, _ = self.store.generate_msgdef(typename, ros_version=2)
                sid = self._writer.register_schema(typename, "ros2msg", text.encode())
                self._schemas[typename] = sid
            cid = self._writer.register_channel(
                topic, "cdr", sid, metadata={"offered_qos_profiles": offered_qos_profiles(latched)})
            self._channels[topic] = cid
        return cid

    def write(self, topic: str, message: Any, t_ns: int, latched: bool = False) -> None:
        """Append one message; a topic's first message decides its QoS (`latched`: published
        once, transient-local, like /tf_static). It is serialised now (a message changed
        afterwards is logged as it was) and goes into the file with the next batch."""
        typename = message.__msgtype__
        cid = self._channel(topic, typename, latched)
        self._append(cid, self._cdr(cid, message, typename), t_ns)

    def write_cdr(self, topic: str, typename: str, data: bytes | memoryview, t_ns: int,
                  latched: bool = False) -> None:
        """Append one message already serialised as CDR (kartci.logs.poses writes a long pose
        stream in bulk)."""
        self._append(self._channel(topic, typename, latched), data, t_ns)

    def _append(self, cid: int, data: bytes | memoryview, t_ns: int) -> None:
        seq = self._seq.get(cid, 0)
        self._seq[cid] = seq + 1
        self._pending.append((cid, seq, t_ns, data))
        if len(self._pending) >= BATCH:
            self._flush()

    def _cdr(self, cid: int, message: Any, typename: str) -> bytes | memoryview:
        """The message's CDR: by one of its topic's fixed layouts when one fits (a new one
        is made from it while the topic has fewer than LAYOUTS), else by rosbags. A topic's
        first message goes to rosbags: making a layout costs more than using it once (the
        track's Path and the world's markers, published once, took 90 ms of a 10 s kart run)."""
        layouts = self._layouts.setdefault(cid, [])
        for layout in layouts:
            data = layout(message)
            if data is not None:
                return data
        if len(layouts) < LAYOUTS and cid in self._seq:
            made = compile_fixed(self.store, message)  # checked on this very message
            if made is not None:
                layouts.append(made)
                data = made(message)
                if data is not None:
                    return data
        return self.store.serialize_cdr(message, typename)

    def _flush(self) -> None:
        """The messages held so far into the writer's chunk."""
        if self._pending:
            batch, self._pending = self._pending, []
            self._chunks.add(batch)

    def close(self, ok: bool = True) -> None:
        """Finish the log and move it into place (`ok`), or throw it away; any failure on the
        way removes the partial file too."""
        if not ok:
            self._discard()
            return
        try:
            self._flush()
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._file.close()
            os.chmod(self._tmp, 0o644)  # mkstemp makes 0600; a log is a shared artifact
            check_target(self.path)  # again: the name may have changed during the run
            os.replace(self._tmp, self.path)
        except BaseException:
            self._discard()
            raise

    def _discard(self) -> None:
        try:
            self._file.close()
        except OSError:
            pass  # the buffered rest could not be written either: the file goes anyway
        finally:
            self._tmp.unlink(missing_ok=True)

    def __enter__(self) -> McapLogWriter:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close(ok=exc_type is None)
