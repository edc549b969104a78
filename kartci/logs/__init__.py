"""Logs: writing runs as MCAP (ROS 2 types, CDR) and reading ROS 1 / ROS 2 / MCAP logs."""

from pathlib import Path

from kartci.errors import LogError
from kartci.logs.reader import TopicInfo, messages, open_log, topics
from kartci.logs.tables import tables
from kartci.logs.types import header, msg, stamp_ns, typestore
from kartci.logs.writer import McapLogWriter


def extract(src: Path, wanted: list[str], dst: Path) -> int:
    """Copy some topics of any log into a new MCAP file (ROS 2 types); returns the count."""
    known = {i.topic for i in topics(src)}
    missing = [t for t in wanted if t not in known]
    if missing:
        raise LogError(f"{src}: no topic {', '.join(missing)} (topics: {', '.join(sorted(known))})")
    n = 0
    with McapLogWriter(dst) as out:
        for topic, t_ns, m in messages(src, wanted):
            out.write(topic, m, t_ns)
            n += 1
    return n

__all__ = [
    "McapLogWriter",
    "TopicInfo",
    "extract",
    "header",
    "messages",
    "msg",
    "open_log",
    "stamp_ns",
    "tables",
    "topics",
    "typestore",
]
