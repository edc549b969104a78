"""Write a run log: one MCAP file, ROS 2 profile, CDR messages with embedded ros2msg schemas."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

from mcap.writer import CompressionType, Writer
from rosbags.typesys.store import Typestore

from kartci.logs.qos import offered_qos_profiles
from kartci.logs.types import typestore


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

    def _channel(self, topic: str, typename: str, latched: bool) -> int:
        cid = self._channels.get(topic)
        if cid is None:
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
        once, transient-local, like /tf_static)."""
        typename = message.__msgtype__
        self.write_cdr(topic, typename, self.store.serialize_cdr(message, typename), t_ns,
                       latched)

    def write_cdr(self, topic: str, typename: str, data: bytes | memoryview, t_ns: int,
                  latched: bool = False) -> None:
        """Append one message already serialised as CDR (kartci.logs.poses writes a long pose
        stream in bulk)."""
        cid = self._channel(topic, typename, latched)
        seq = self._seq.get(cid, 0)
        self._seq[cid] = seq + 1
        self._writer.add_message(cid, log_time=t_ns, data=bytes(data), publish_time=t_ns,
                                 sequence=seq)

    def close(self, ok: bool = True) -> None:
        """Finish the log and move it into place (`ok`), or throw it away; any failure on the
        way removes the partial file too."""
        if not ok:
            self._discard()
            return
        try:
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._file.close()
            os.chmod(self._tmp, 0o644)  # mkstemp makes 0600; a log is a shared artifact
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
