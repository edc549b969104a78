"""Where two logs diverge: the first message, in log-time order, whose content, log time or
presence differs, with its differing fields.

Messages are paired by topic and index on that topic (the k-th /kart0/odom of A with the k-th
of B) and compared byte for byte while both logs stream in time order; only a pair whose bytes
differ is decoded and walked field by field, and reading stops at the first difference, so two
identical 30 s run logs compare in about the time it takes to read them. Floats compare exactly
(bitwise, except that NaN equals NaN) unless a tolerance is given. The fields measured on the
wall clock (kartci.logs.wallclock) are left out unless asked for.
"""

from __future__ import annotations

import dataclasses
import fnmatch
import math
import re
from collections import Counter, defaultdict, deque
from collections.abc import Iterator
from contextlib import ExitStack
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from kartci.errors import LogError, SpecError
from kartci.logs.reader import LogReader, Raw, TopicInfo, open_log
from kartci.logs.wallclock import wall_clock_fields


class Absent(Enum):
    """The value of a field that one log's message type does not have."""

    ABSENT = "absent"


ABSENT = Absent.ABSENT


@dataclass(frozen=True)
class FieldDiff:
    """One differing field: its dotted path (array elements as `[i]`, an array's length as
    `len(path)`) and its value in A and in B (ABSENT where that log's type lacks the field)."""

    path: str
    a: Any
    b: Any

    @property
    def delta(self) -> float | None:
        """B - A for two numbers (bools are not), else None."""
        if (isinstance(self.a, int | float) and isinstance(self.b, int | float)
                and not isinstance(self.a, bool) and not isinstance(self.b, bool)):
            return self.b - self.a
        return None


@dataclass(frozen=True)
class MessageDiff:
    """The first differing message. A log time of None: that log has no message `index` on the
    topic (it has `counts` messages on it, A's and B's)."""

    topic: str
    msgtype: str
    index: int  # on its topic, from 0
    t_a_ns: int | None  # log time in A, ns
    t_b_ns: int | None  # log time in B, ns
    fields: tuple[FieldDiff, ...]  # the first differing fields, in message order
    more_fields: int  # how many more fields differ
    counts: tuple[int, int]  # messages on the topic in A and in B

    @property
    def t_ns(self) -> int:
        """When the logs part: the earlier of the two log times, ns."""
        return min(t for t in (self.t_a_ns, self.t_b_ns) if t is not None)


class TopicChange(Enum):
    """How a topic differs as a whole."""

    ONLY_A = "only in A"
    ONLY_B = "only in B"
    TYPE = "different message types"
    COUNT = "different message counts"


@dataclass(frozen=True)
class TopicDiff:
    """A topic that differs as a whole (None: the log lacks it)."""

    topic: str
    change: TopicChange
    a: TopicInfo | None
    b: TopicInfo | None


class SkipReason(Enum):
    """Why a field was not compared."""

    WALL_CLOCK = "wall clock"
    IGNORED = "--ignore"


@dataclass(frozen=True)
class Skipped:
    """A field left out of the comparison on a topic, in each of `messages` message pairs."""

    topic: str
    field: str
    reason: SkipReason
    messages: int


@dataclass(frozen=True)
class Ignore:
    """A topic (`*` wildcards allowed) or one dotted field of it (array indices left out:
    `poses.pose.position.x`) that is not compared."""

    topic: str
    field: str | None = None  # None: the whole topic

    @classmethod
    def parse(cls, text: str) -> Ignore:
        """`TOPIC` or `TOPIC:FIELD` (ROS topic names have no colon)."""
        topic, sep, field = text.partition(":")
        if not topic or (sep and not field):
            raise SpecError(f"--ignore {text}: expected TOPIC or TOPIC:FIELD, "
                            "e.g. /kart0/mpcc/stats:cost")
        return cls(topic, field or None)

    def matches(self, topic: str) -> bool:
        """Whether this covers `topic`."""
        return fnmatch.fnmatchcase(topic, self.topic)

    def __str__(self) -> str:
        return self.topic if self.field is None else f"{self.topic}:{self.field}"


@dataclass(frozen=True)
class DiffOptions:
    """What counts as a difference."""

    tolerance: float = 0.0  # absolute, in each float field's own unit; 0: bitwise equal
    wall_clock: bool = False  # compare the fields measured on the wall clock too
    ignore: tuple[Ignore, ...] = ()
    max_fields: int = 10  # differing fields kept of the first differing message

    def __post_init__(self) -> None:
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0):
            raise SpecError(f"--tolerance {self.tolerance}: expected a number >= 0")
        if self.max_fields < 1:
            raise SpecError(f"--fields {self.max_fields}: expected a number >= 1")


@dataclass(frozen=True)
class LogDiff:
    """The outcome: identical when no topic differs as a whole and no message differs."""

    compared: int  # message pairs compared (reading stops at the first difference)
    topics: int  # topics compared message by message
    first: MessageDiff | None
    topic_diffs: tuple[TopicDiff, ...]
    skipped: tuple[Skipped, ...]
    ignored_topics: tuple[str, ...]
    unused_ignores: tuple[Ignore, ...]  # --ignore entries that match no topic of either log

    @property
    def identical(self) -> bool:
        """Whether the logs agree on everything compared."""
        return self.first is None and not self.topic_diffs


_INDEX = re.compile(r"\[\d+\]")


class _Fields:
    """Walks two decoded messages; keeps the first `limit` differing fields, counts all."""

    def __init__(self, skip: tuple[str, ...], tolerance: float, limit: int) -> None:
        self._skip = skip
        self._tol = tolerance
        self._limit = limit
        self.found: list[FieldDiff] = []
        self.total = 0

    def add(self, path: str, a: Any, b: Any) -> None:
        self.total += 1
        if len(self.found) < self._limit:
            self.found.append(FieldDiff(path, a, b))

    def walk(self, a: Any, b: Any, path: str) -> None:
        if self._skipped(path):
            return
        if _is_message(a) and _is_message(b):
            self._message(a, b, path)
        elif isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
            self._array(a, b, path)
        elif isinstance(a, list) and isinstance(b, list):
            if len(a) != len(b):
                self.add(f"len({path})", len(a), len(b))
            for i, (x, y) in enumerate(zip(a, b, strict=False)):
                self.walk(x, y, f"{path}[{i}]")
        elif not _same(a, b, self._tol):
            self.add(path, a, b)

    def _skipped(self, path: str) -> bool:
        if not self._skip or not path:
            return False
        bare = _INDEX.sub("", path)
        return any(bare == f or bare.startswith(f"{f}.") for f in self._skip)

    def _message(self, a: Any, b: Any, path: str) -> None:
        names_a, names_b = _names(a), _names(b)
        for name in [*names_a, *(n for n in names_b if n not in names_a)]:
            self.walk(getattr(a, name, ABSENT), getattr(b, name, ABSENT),
                      f"{path}.{name}" if path else name)

    def _array(self, a: np.ndarray, b: np.ndarray, path: str) -> None:
        if a.dtype != b.dtype:
            self.add(f"dtype({path})", str(a.dtype), str(b.dtype))
            return
        if len(a) != len(b):
            self.add(f"len({path})", len(a), len(b))
        n = min(len(a), len(b))
        x, y = a[:n], b[:n]
        if x.tobytes() == y.tobytes():
            return
        differ = np.flatnonzero(~_same_elements(x, y, self._tol))
        for i in differ[:self._limit]:
            self.add(f"{path}[{i}]", x[i].item(), y[i].item())
        self.total += max(len(differ) - self._limit, 0)


def _is_message(value: Any) -> bool:
    return hasattr(type(value), "__msgtype__") and dataclasses.is_dataclass(value)


def _names(message: Any) -> list[str]:
    return [f.name for f in dataclasses.fields(message)]


def _same(a: Any, b: Any, tol: float) -> bool:
    """Floats: equal bits (so 0.0 differs from -0.0), NaN equal to NaN; or within `tol`."""
    if isinstance(a, float) and isinstance(b, float):
        if math.isnan(a) and math.isnan(b):
            return True
        if a == b:
            return tol > 0 or math.copysign(1.0, a) == math.copysign(1.0, b)
        return abs(a - b) <= tol
    return type(a) is type(b) and bool(a == b)


def _same_elements(x: np.ndarray, y: np.ndarray, tol: float) -> np.ndarray:
    """`_same` element by element."""
    if x.dtype.kind != "f":
        return np.asarray(x == y)
    with np.errstate(invalid="ignore", over="ignore"):
        same = (x == y) & (np.signbit(x) == np.signbit(y)) if tol == 0 else (
            (x == y) | (np.abs(x - y) <= tol))
    return np.asarray(same | (np.isnan(x) & np.isnan(y)))


@dataclass(frozen=True)
class _Topic:
    """A topic compared message by message: its type, listed counts and skipped fields."""

    msgtype: str
    counts: tuple[int, int]
    skip: tuple[tuple[str, SkipReason], ...]


class _Side:
    """One log's stream, with the messages read but not yet paired with the other log's."""

    def __init__(self, log: LogReader, topics: list[str], listed: dict[str, int]) -> None:
        self.log = log
        self._it: Iterator[Raw] = log.raw(topics) if topics else iter(())
        self._listed = listed
        self.read: Counter[str] = Counter()
        self.waiting: dict[str, deque[tuple[int, Raw]]] = defaultdict(deque)
        self.head: Raw | None = next(self._it, None)

    def t_next(self) -> float:
        return math.inf if self.head is None else self.head[3]

    def take(self) -> tuple[int, Raw]:
        raw = self.head
        assert raw is not None
        self.head = next(self._it, None)
        index = self.read[raw[0]]
        self.read[raw[0]] += 1
        return index, raw

    def ended(self, topic: str) -> bool:
        """Whether this log has no more messages on `topic` (its listed count is read)."""
        return self.head is None or self.read[topic] >= self._listed.get(topic, 0)

    def oldest_waiting(self) -> float:
        return min((q[0][1][3] for q in self.waiting.values() if q), default=math.inf)


class _Comparison:
    """Both streams, read in time order, paired by topic and index."""

    def __init__(self, a: _Side, b: _Side, topics: dict[str, _Topic],
                 options: DiffOptions) -> None:
        self.a, self.b = a, b
        self.topics = topics
        self.options = options
        self.compared: Counter[str] = Counter()

    def first(self) -> MessageDiff | None:
        best: MessageDiff | None = None
        while self.a.head is not None or self.b.head is not None:
            found = self._step()
            if found is not None and (best is None or found.t_ns < best.t_ns):
                best = found
            if best is not None and best.t_ns <= self._bound():
                return best
        for side in (self.a, self.b):  # listed counts too high: what is still unpaired
            for queue in side.waiting.values():
                for index, raw in queue:
                    found = self._unpaired(side, index, raw)
                    if best is None or found.t_ns < best.t_ns:
                        best = found
        return best

    def _bound(self) -> float:
        """No difference found later can lie before this log time."""
        return min(self.a.t_next(), self.b.t_next(), self.a.oldest_waiting(),
                   self.b.oldest_waiting())

    def _step(self) -> MessageDiff | None:
        side, other = (self.a, self.b) if self.a.t_next() <= self.b.t_next() else (
            self.b, self.a)
        index, raw = side.take()
        topic = raw[0]
        if other.waiting[topic]:
            _, partner = other.waiting[topic].popleft()
            self.compared[topic] += 1
            return self._pair(index, *((raw, partner) if side is self.a else (partner, raw)))
        if other.ended(topic):
            return self._unpaired(side, index, raw)
        side.waiting[topic].append((index, raw))
        return None

    def _unpaired(self, side: _Side, index: int, raw: Raw) -> MessageDiff:
        info = self.topics[raw[0]]
        t_a, t_b = (raw[3], None) if side is self.a else (None, raw[3])
        return MessageDiff(raw[0], info.msgtype, index, t_a, t_b, (), 0, info.counts)

    def _pair(self, index: int, ra: Raw, rb: Raw) -> MessageDiff | None:
        same_bytes = ra[2] == rb[2] and ra[4] == rb[4]
        if same_bytes and ra[3] == rb[3]:
            return None
        info = self.topics[ra[0]]
        fields: tuple[FieldDiff, ...] = ()
        more = 0
        if not same_bytes:
            fields, more = self._fields(ra, rb, info)
            if not fields and ra[3] == rb[3]:
                return None  # only skipped fields (or padding bytes) differ
        return MessageDiff(ra[0], info.msgtype, index, ra[3], rb[3], fields, more, info.counts)

    def _fields(self, ra: Raw, rb: Raw, info: _Topic) -> tuple[tuple[FieldDiff, ...], int]:
        ma, mb = self.a.log.decode(ra), self.b.log.decode(rb)
        walk = _Fields(tuple(f for f, _ in info.skip), self.options.tolerance,
                       self.options.max_fields)
        if ma is None or mb is None:
            walk.add("(message)", "does not decode" if ma is None else f"{len(ra[4])} bytes",
                     "does not decode" if mb is None else f"{len(rb[4])} bytes")
        else:
            walk.walk(ma, mb, "")
        return tuple(walk.found), walk.total - len(walk.found)


def _listed(log: LogReader) -> dict[str, TopicInfo]:
    """Topics by name; a topic on several connections counts all its messages."""
    out: dict[str, TopicInfo] = {}
    for info in log.topics():
        seen = out.get(info.topic)
        out[info.topic] = info if seen is None else dataclasses.replace(
            seen, count=seen.count + info.count)
    return out


def _skips(topic: str, msgtype: str, options: DiffOptions) -> tuple[tuple[str, SkipReason], ...]:
    wall = () if options.wall_clock else wall_clock_fields(msgtype)
    return (*((f, SkipReason.WALL_CLOCK) for f in wall),
            *((i.field, SkipReason.IGNORED) for i in options.ignore
              if i.field is not None and i.matches(topic)))


def _plan(ia: dict[str, TopicInfo], ib: dict[str, TopicInfo],
          options: DiffOptions) -> tuple[dict[str, _Topic], list[TopicDiff], list[str]]:
    """The topics to compare message by message, those that differ as a whole, and those
    ignored."""
    compared: dict[str, _Topic] = {}
    whole: list[TopicDiff] = []
    ignored: list[str] = []
    for topic in sorted(ia.keys() | ib.keys()):
        a, b = ia.get(topic), ib.get(topic)
        if any(i.field is None and i.matches(topic) for i in options.ignore):
            ignored.append(topic)
        elif a is None or b is None:
            whole.append(TopicDiff(topic, TopicChange.ONLY_B if a is None else TopicChange.ONLY_A,
                                   a, b))
        elif a.msgtype != b.msgtype:
            whole.append(TopicDiff(topic, TopicChange.TYPE, a, b))
        else:
            if a.count != b.count:
                whole.append(TopicDiff(topic, TopicChange.COUNT, a, b))
            compared[topic] = _Topic(a.msgtype, (a.count, b.count),
                                     _skips(topic, a.msgtype, options))
    return compared, whole, ignored


def _opened(stack: ExitStack, path: Path, which: str) -> LogReader:
    try:
        return stack.enter_context(open_log(path))
    except LogError as err:
        raise LogError(f"{which}: {err}; expected a run log (.mcap) or a run folder") from err


def diff_logs(a: Path, b: Path, options: DiffOptions | None = None) -> LogDiff:
    """Compare log `a` with log `b` (any log kartci reads) up to their first difference."""
    options = options or DiffOptions()
    with ExitStack() as stack:
        la, lb = _opened(stack, a, "A"), _opened(stack, b, "B")
        ia, ib = _listed(la), _listed(lb)
        topics, whole, ignored = _plan(ia, ib, options)
        names = list(topics)
        run = _Comparison(_Side(la, names, {t: i.count for t, i in ia.items()}),
                          _Side(lb, names, {t: i.count for t, i in ib.items()}), topics, options)
        first = run.first()
    skipped = tuple(Skipped(topic, f, why, run.compared[topic])
                    for topic, info in topics.items() for f, why in info.skip)
    every = ia.keys() | ib.keys()
    unused = tuple(i for i in options.ignore if not any(i.matches(t) for t in every))
    return LogDiff(sum(run.compared.values()), len(topics), first, tuple(whole), skipped,
                   tuple(ignored), unused)


__all__ = ["ABSENT", "DiffOptions", "FieldDiff", "Ignore", "LogDiff", "MessageDiff",
           "SkipReason", "Skipped", "TopicChange", "TopicDiff", "diff_logs"]
