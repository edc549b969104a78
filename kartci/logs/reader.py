"""Read any log (ROS 1 .bag, rosbag2 directory, bare .mcap) through rosbags' AnyReader, and what
is readable of a damaged one by streaming through it.

A healthy log is read once, through its index, as rosbags reads it. When rosbags cannot open a
log, or fails part way through its messages (a damaged chunk, a damaged summary), the log is
read again by streaming (kartci.logs.salvage), and what could be read is returned with a
SalvagedLog warning that says so; reading resumes after the last message already returned.
Every failure that leaves nothing to return is one LogError, `<path>: <what is wrong>`.
"""

from __future__ import annotations

import warnings
from collections import Counter
from collections.abc import Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from rosbags.highlevel import AnyReader
from rosbags.typesys.store import Typestore

from kartci.boundedio import RefusedFileError, check_log
from kartci.errors import LogError
from kartci.logs import mcapfast
from kartci.logs.damage import count_of, describe
from kartci.logs.salvage import NotStreamableError, Salvage, salvage
from kartci.logs.types import from_definitions, typestore

Raw = tuple[str, str, bool, int, bytes]  # topic, msgtype, ROS 1 encoded, log time ns, bytes
_SHOWN: dict[Any, Any] = {}  # the warnings registry of SalvagedLog notes


class SalvagedLog(UserWarning):
    """A log was only partly readable; the message is one line, `<path>: <what happened>`."""


@dataclass(frozen=True)
class TopicInfo:
    topic: str
    msgtype: str
    count: int


class _Source(Protocol):
    store: Typestore

    def topics(self) -> list[TopicInfo]: ...
    def raw(self, wanted: Sequence[str] | None) -> Iterator[Raw]: ...
    def close(self) -> None: ...


class _Indexed:
    """A log rosbags could open: read through its index."""

    def __init__(self, reader: AnyReader) -> None:
        self._reader = reader
        self.store = reader.typestore
        self._ros1 = not reader.is2

    def topics(self) -> list[TopicInfo]:
        return [TopicInfo(c.topic, c.msgtype, c.msgcount) for c in self._reader.connections]

    def raw(self, wanted: Sequence[str] | None) -> Iterator[Raw]:
        conns = [c for c in self._reader.connections if wanted is None or c.topic in wanted]
        if not conns:  # AnyReader reads every topic when given none
            return
        got = 0
        fast = mcapfast.messages(self._reader, conns)  # a rosbag2 MCAP: the same, faster
        for conn, t_ns, data in fast if fast is not None else self._reader.messages(
                connections=conns):
            got += 1
            yield conn.topic, conn.msgtype, self._ros1, t_ns, data
        listed = sum(c.msgcount for c in conns)
        if got < listed:  # an index that points at less than it lists (or a rosbags quirk)
            raise _ShortReadError(f"its index or metadata lists {listed} messages of these "
                                  f"topics, reading through it gave {got}")

    def close(self) -> None:
        with suppress(Exception):  # closing after a failure may fail again; nothing to save
            self._reader.close()


class _Streamed:
    """What streaming salvaged, held in memory; topics whose type is unusable are listed but
    yield nothing."""

    def __init__(self, found: Salvage) -> None:
        defs = {(c.msgtype, c.fmt, c.text) for c in found.conns.values()}
        self.store, self.problems = from_definitions(sorted(defs))
        self._found = found
        self.unusable = sorted({c.msgtype for c in found.conns.values()
                                if not _usable(self.store, c.msgtype)})

    def topics(self) -> list[TopicInfo]:
        counts = self._found.counts()
        return [TopicInfo(c.topic, c.msgtype, counts[key]) for key, c in self._found.conns.items()]

    def raw(self, wanted: Sequence[str] | None) -> Iterator[Raw]:
        conns = {key: c for key, c in self._found.conns.items()
                 if (wanted is None or c.topic in wanted) and c.msgtype not in self.unusable}
        for t_ns, key, data in self._found.in_time_order():
            c = conns.get(key)
            if c is not None:
                yield c.topic, c.msgtype, c.ros1, t_ns, data

    def close(self) -> None:
        pass


class _Empty:
    """No more messages: what a log that cannot be streamed continues with after a short read."""

    def __init__(self, topics: list[TopicInfo], store: Typestore) -> None:
        self._topics = topics
        self.store = store

    def topics(self) -> list[TopicInfo]:
        return self._topics

    def raw(self, wanted: Sequence[str] | None) -> Iterator[Raw]:
        return iter(())

    def close(self) -> None:
        pass


def _usable(store: Typestore, msgtype: str) -> bool:
    try:
        store.get_msgdef(msgtype)
    except Exception:  # a missing or broken type fails in many ways
        return False
    return True


class _ShortReadError(Exception):
    """The index-based reader ended early; the words are the message."""


class _SourceFailedError(Exception):
    def __init__(self, err: Exception) -> None:
        super().__init__(str(err))
        self.err = err


@dataclass
class _Position:
    """How far messages() got: the last log time returned and the topics returned at that
    time, so that reading can resume in another reader without repeating a message. Kept per
    message on healthy logs too, so it is kept cheap: a list, not a Counter."""

    t_ns: int = -1
    at_t: list[str] = field(default_factory=list)

    def passed(self, topic: str, t_ns: int) -> None:
        if t_ns != self.t_ns:
            self.t_ns = t_ns
            self.at_t = [topic]
        else:
            self.at_t.append(topic)

    def seen(self, topic: str, t_ns: int) -> bool:
        """In the resumed reader: whether this message was already returned (or lies before
        what was returned: then it can only come from the damaged part)."""
        if t_ns < self.t_ns:
            return True
        if t_ns == self.t_ns and topic in self.at_t:
            self.at_t.remove(topic)
            return True
        return False


def warn_salvaged(text: str) -> None:
    """Warn that a log was only partly read. Issued as if from "kartci", line 0, so that
    Python's default display is one line (`kartci:0: SalvagedLog: <path>: ...`) and not two
    with a line of kartci's source; the registry shows a note once, however often the log is
    read."""
    warnings.warn_explicit(SalvagedLog(text), SalvagedLog, "kartci", 0, module=__name__,
                           registry=_SHOWN)


class LogReader:
    """An open log. `notes` lists, one line each, what was wrong and what was salvaged; empty
    when the log read cleanly. Each note is also issued as a SalvagedLog warning."""

    def __init__(self, path: Path, source: _Source) -> None:
        self.path = path
        self.notes: list[str] = []
        self._source = source
        self._checked: set[str] = set()
        self._undecodable: Counter[str] = Counter()
        self._why: dict[str, str] = {}

    @property
    def salvaged(self) -> bool:
        return bool(self.notes)

    @property
    def typestore(self) -> Typestore:
        """The message types as this log defines them."""
        return self._source.store

    def topics(self) -> list[TopicInfo]:
        return self._source.topics()

    def messages(self, wanted: Sequence[str] | None = None) -> Iterator[tuple[str, int, Any]]:
        """Yield (topic, log time ns, message) in time order, for the wanted topics (default
        all). Messages that do not decode are skipped and reported once at the end."""
        for raw in self.raw(wanted):
            m = self.decode(raw)
            if m is not None:
                yield raw[0], raw[3], m
        self.report_undecodable()

    def raw(self, wanted: Sequence[str] | None = None) -> Iterator[Raw]:
        """Like messages(), but undecoded: (topic, msgtype, ROS 1 encoded, log time ns, bytes).
        For comparing logs byte for byte, decoding (decode()) only what differs."""
        position = _Position()
        try:
            yield from self._raws(wanted, position, resume=False)
        except _SourceFailedError as failed:
            self._fall_back(failed.err)
            yield from self._raws(wanted, position, resume=True)

    def decode(self, raw: Raw) -> Any:
        """One message of raw(), decoded with this log's types; None when it does not decode
        (counted, and reported once at the end of messages())."""
        topic, msgtype, ros1, _, data = raw
        return self._decode(topic, msgtype, ros1, data)

    def close(self) -> None:
        self._source.close()

    def note(self, text: str) -> None:
        """Keep the note and warn (warn_salvaged)."""
        self.notes.append(text)
        warn_salvaged(text)

    def _raws(self, wanted: Sequence[str] | None, position: _Position,
              resume: bool) -> Iterator[Raw]:
        passed, seen = position.passed, position.seen
        try:  # only the source raises in here (GeneratorExit at the yield is no Exception)
            for raw in self._source.raw(wanted):
                if not resume:
                    passed(raw[0], raw[3])
                elif seen(raw[0], raw[3]):  # the position stays where the first reader left
                    continue  # off: two messages of a topic at one time are both new here
                yield raw
        except Exception as err:  # damaged bytes make readers raise anything
            raise _SourceFailedError(err) from err

    def _decode(self, topic: str, msgtype: str, ros1: bool, data: bytes) -> Any:
        store = self._source.store
        if msgtype not in self._checked:
            self._check_type(topic, msgtype)
        try:
            return store.deserialize_ros1(data, msgtype) if ros1 else store.deserialize_cdr(
                data, msgtype)
        except Exception as err:  # the decoders raise anything on bad bytes
            self._undecodable[topic] += 1
            self._why.setdefault(topic, f"{msgtype}: {describe(err)}")
            return None

    def _check_type(self, topic: str, msgtype: str) -> None:
        try:
            self._source.store.get_msgdef(msgtype)
        except KeyError as err:
            raise LogError(f"{self.path}: cannot decode {topic}: type {err.args[0]} is neither "
                           "defined in the log nor known to kartci") from err
        except Exception as err:  # a broken definition fails in many ways
            raise LogError(f"{self.path}: cannot decode {topic} ({msgtype}): "
                           f"{describe(err)}") from err
        self._checked.add(msgtype)

    def _fall_back(self, err: Exception) -> None:
        """Continue by streaming; after a short read that cannot stream, what was read stands."""
        listed, store = self._source.topics(), self._source.store
        self._source.close()
        why = str(err) if isinstance(err, _ShortReadError) else describe(err)
        try:
            self._source, text = _salvaged(self.path, why, err)
        except LogError:
            if not isinstance(err, _ShortReadError):
                raise
            self._source, text = _Empty(listed, store), f"{self.path}: {why}"
        self._checked.clear()
        self.note(text)

    def report_undecodable(self) -> None:
        """Note the messages decode() could not decode since the last note (messages() does
        this at its end; a caller of raw() and decode() calls it itself)."""
        if not self._undecodable:
            return
        parts = [f"{n} on {topic} ({self._why[topic]})" for topic, n in
                 sorted(self._undecodable.items())]
        self._undecodable.clear()
        self.note(f"{self.path}: skipped messages that do not decode: {'; '.join(parts)}")


def _salvaged(path: Path, why: str, err: Exception) -> tuple[_Streamed, str]:
    """The streamed source for a log rosbags failed on, and the note that says so; LogError
    when streaming is impossible or finds nothing."""
    try:
        found = salvage(path)
    except (NotStreamableError, OSError):
        raise LogError(f"{path}: {why}") from err
    if not found.conns:
        raise LogError(f"{path}: {why}; reading it {found.how} found no topics either"
                       + "".join(f"; {x}" for x in found.problems)) from err
    source = _Streamed(found)
    extra = [*found.problems, *source.problems]
    if found.skipped_chunks:
        extra.append(f"{count_of(found.skipped_chunks, 'damaged chunk')} not fully read")
    if source.unusable:
        extra.append(f"no usable definition of {', '.join(source.unusable)}")
    counts = found.counts()
    n = sum(counts[key] for key in found.conns)
    read = f"{count_of(n, 'message')} on {count_of(len(found.conns), 'topic')}"
    return source, (f"{path}: {why}; read {found.how}: {read}"
                    + "".join(f"; {x}" for x in extra))



def _check(path: Path) -> None:
    """A log is a regular file or a rosbag2 folder of them: a FIFO would hang the reader."""
    try:
        check_log(path)
    except FileNotFoundError as err:
        raise LogError(f"{path}: no such file or directory") from err
    except (OSError, ValueError) as err:  # ValueError: a NUL character in the path
        raise LogError(f"{path}: {err if isinstance(err, RefusedFileError) else describe(err)}"
                       ) from err


def _open(path: Path) -> LogReader:
    _check(path)
    try:
        reader = AnyReader([path], default_typestore=typestore())
        reader.open()
    except Exception as err:  # damaged bytes make readers raise anything
        source, text = _salvaged(path, describe(err), err)
        log = LogReader(path, source)
        log.note(text)
        return log
    return LogReader(path, _Indexed(reader))


@contextmanager
def open_log(path: Path) -> Iterator[LogReader]:
    """Open any log; LogError (one line, naming the file) when nothing in it can be read."""
    log = _open(path)
    try:
        yield log
    finally:
        log.close()


def topics(path: Path) -> list[TopicInfo]:
    with open_log(path) as log:
        return log.topics()


def messages(path: Path, wanted: Sequence[str] | None = None) -> Iterator[tuple[str, int, Any]]:
    """Yield (topic, log time ns, message) in time order, for the wanted topics (default all)."""
    with open_log(path) as log:
        yield from log.messages(wanted)


__all__ = ["LogReader", "Raw", "SalvagedLog", "TopicInfo", "messages", "open_log", "topics",
           "warn_salvaged"]
