"""Logs: writing runs as MCAP (ROS 2 types, CDR) and reading ROS 1 / ROS 2 / MCAP logs."""

import warnings
from functools import cache
from pathlib import Path
from typing import Any

from rosbags.typesys.store import Typestore

from kartci.errors import LogError
from kartci.logs.damage import describe
from kartci.logs.reader import (
    LogReader,
    SalvagedLog,
    TopicInfo,
    messages,
    open_log,
    topics,
    warn_salvaged,
)
from kartci.logs.tables import tables
from kartci.logs.types import SCENARIO_TOPIC, for_writing, header, msg, stamp_ns, typestore
from kartci.logs.writer import McapLogWriter


def _same(a: Path, b: Path) -> bool:
    if a.resolve() == b.resolve():
        return True
    try:
        return a.samefile(b)  # hard links
    except OSError:
        return False


def _check_output(src: Path, dst: Path) -> None:
    """Refuse an output that would replace or write into the log being read: the writer
    truncates its `<dst>.partial` and renames it over `dst` at the end."""
    partial = dst.with_name(dst.name + ".partial")
    if _same(src, dst) or _same(src, partial):
        raise LogError(f"{dst}: is the log being read; choose another output file")
    if src.is_dir() and src.resolve() in dst.resolve().parents:
        raise LogError(f"{dst}: is inside the log folder being read ({src}); "
                       "choose an output outside it")
    if dst.is_dir():
        raise LogError(f"{dst}: is a folder; give the path of the .mcap file to write")


@cache
def ros1_renames() -> dict[str, str]:
    """ROS 1 message types renamed in ROS 2 (rosbags.convert's table, and its migration of the
    fields): written under the ROS 2 name, so ROS 2 tools read the copy."""
    # start-up: rosbags.convert costs 0.1 s on import; only extract needs it
    from rosbags.convert.converter import STATIC_MSGTYPE_RENAMES

    return {**STATIC_MSGTYPE_RENAMES, "rosgraph_msgs/msg/Log": "rcl_interfaces/msg/Log"}


# ROS 1 Log levels (1, 2, 4, 8, 16) -> ROS 2's (10, 20, 30, 40, 50)
_LOG_LEVELS = {1: 10, 2: 20, 4: 30, 8: 40, 16: 50}


def ros2_message(m: Any, src: Typestore, dst: Typestore, cache: dict[str, object]) -> Any:
    """`m` as its ROS 2 type when ROS 2 renamed it (ros1_renames), else `m` itself."""
    from rosbags.convert.converter import migrate_message  # start-up: see ros1_renames

    name = ros1_renames().get(m.__msgtype__)
    if name is None or name not in dst.fielddefs:
        return m
    out: Any = migrate_message(src, dst, m.__msgtype__, name, cache, m)
    if name == "rcl_interfaces/msg/Log":  # the header's stamp; the level's new scale
        out.stamp = dst.types["builtin_interfaces/msg/Time"](
            sec=m.header.stamp.sec, nanosec=m.header.stamp.nanosec)
        out.level = _LOG_LEVELS.get(int(m.level), int(m.level))
    return out


def _write(out: McapLogWriter, log: LogReader, topic: str, m: Any, t_ns: int) -> None:
    try:
        out.write(topic, m, t_ns)
    except OSError as err:
        raise LogError(f"{out.path}: cannot write ({err.strerror or err})") from err
    except Exception as err:  # the CDR serializer raises anything on a mismatch
        raise LogError(f"{log.path}: {topic} ({m.__msgtype__}) cannot be written as ROS 2 CDR: "
                       f"{describe(err)}") from err


def extract(src: Path, wanted: list[str], dst: Path) -> int:
    """Copy some topics of any log into a new MCAP file (ROS 2 types, ROS 1 names renamed as
    ros1_renames says); returns the count.

    Types that only the log defines (a ROS 1 bag's turtlesim/msg/Pose) are written with the
    log's own definitions. The file appears only when the copy is complete (see
    McapLogWriter); from a damaged log, what could be salvaged is copied (SalvagedLog warns).
    A copy with no message is a LogError that says why, and writes nothing."""
    _check_output(src, dst)
    with warnings.catch_warnings():  # the notes are told with the outcome: in the error, or after
        warnings.simplefilter("ignore", SalvagedLog)
        n, notes = _extract(src, wanted, dst)
    for text in notes:
        warn_salvaged(text)
    return n


def recover(src: Path, dst: Path) -> int:
    """Every readable message of every topic of `src` (damaged or not) into `dst`; returns the
    count. What was lost is in the SalvagedLog warning; nothing readable is a LogError."""
    with warnings.catch_warnings():  # told once: by extract, or in the error
        warnings.simplefilter("ignore", SalvagedLog)
        with open_log(src) as log:
            wanted = [i.topic for i in log.topics() if i.count > 0]
            notes = list(log.notes)
    if not wanted:
        why = "; ".join(t.removeprefix(f"{src}: ") for t in notes)
        raise LogError(f"{src}: no message could be read{f' ({why})' if why else ''}; nothing "
                       f"written to {dst}")
    return extract(src, wanted, dst)


def _extract(src: Path, wanted: list[str], dst: Path) -> tuple[int, list[str]]:
    with open_log(src) as log:
        known = {i.topic for i in log.topics()}
        missing = [t for t in wanted if t not in known]
        if missing:
            raise LogError(f"{src}: no topic {', '.join(missing)} "
                           f"(topics: {', '.join(sorted(known))})")
        try:
            store = for_writing(log.typestore)
        except Exception as err:  # rosbags' type registry raises anything
            raise LogError(f"{src}: its message types cannot be written as ROS 2 "
                           f"({describe(err)})") from err
        try:
            return _copy(log, wanted, McapLogWriter(dst, store)), log.notes
        except OSError as err:
            raise LogError(f"{dst}: cannot write ({err.strerror or err})") from err


def _copy(log: LogReader, wanted: list[str], out: McapLogWriter) -> int:
    """The messages copied; none is an error (raised inside `with out`, so no file appears)."""
    n = 0
    cache: dict[str, object] = {}
    with out:
        for topic, t_ns, m in log.messages(wanted):
            _write(out, log, topic, ros2_message(m, log.typestore, out.store, cache), t_ns)
            n += 1
        if n == 0:
            prefix = f"{log.path}: "
            why = "; ".join(t.removeprefix(prefix) for t in log.notes) or (
                "the log holds none on " + ("this topic" if len(wanted) == 1 else "these topics"))
            raise LogError(f"{log.path}: no message of {', '.join(wanted)} could be read ({why}); "
                           f"nothing written to {out.path}")
    return n


__all__ = [
    "SCENARIO_TOPIC",
    "LogReader",
    "McapLogWriter",
    "SalvagedLog",
    "TopicInfo",
    "extract",
    "header",
    "messages",
    "msg",
    "open_log",
    "recover",
    "stamp_ns",
    "tables",
    "topics",
    "typestore",
    "warn_salvaged",
]
