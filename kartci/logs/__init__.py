"""Logs: writing runs as MCAP (ROS 2 types, CDR) and reading ROS 1 / ROS 2 / MCAP logs."""

from kartci.logs.reader import TopicInfo, messages, open_log, topics
from kartci.logs.tables import tables
from kartci.logs.types import header, msg, stamp_ns, typestore
from kartci.logs.writer import McapLogWriter

__all__ = ["McapLogWriter", "TopicInfo", "header", "messages", "msg", "open_log", "stamp_ns",
           "tables", "topics", "typestore"]
