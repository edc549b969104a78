"""kartci.logs.mcapfast reads a rosbag2 MCAP's raw messages exactly as rosbags' reader does:
the same messages in the same order, and on a damaged file the same messages before the damage
and the same salvage notes, on chunked files (chunks one after the other, and overlapping in
time), unchunked ones, in and out of time order, with a byte changed anywhere."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import pytest
from mcap.writer import CompressionType, Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as BagWriter
from rosbags.typesys import Stores, get_typestore

from kartci.errors import LogError
from kartci.logs import mcapfast, open_log

_REAL = mcapfast.messages
_CDR = b"\x00\x01\x00\x00"


def _write(path: Path, times: list[int], chunked: bool, compression: CompressionType) -> Path:
    """A bare ros2 MCAP with two std_msgs/String topics (small chunks: many of them)."""
    with path.open("wb") as f:
        w = Writer(f, chunk_size=600, compression=compression, use_chunking=chunked)
        w.start(profile="ros2", library="test")
        sid = w.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        chans = [w.register_channel(t, "cdr", sid) for t in ("/a", "/b")]
        for k, t in enumerate(times):
            text = f"m{k}".encode() + b"\x00"
            data = _CDR + len(text).to_bytes(4, "little") + text
            w.add_message(chans[k % 3 == 0], log_time=t, data=data, publish_time=t, sequence=k)
        w.finish()  # type: ignore[no-untyped-call]
    return path


def _read(path: Path, fast: bool, monkeypatch: pytest.MonkeyPatch) -> Any:
    """Every raw message and the notes; the error's words where nothing can be read."""
    monkeypatch.setattr(mcapfast, "messages", _REAL if fast else lambda reader, conns: None)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with open_log(path) as log:
                got = [(r[0], r[1], r[3], bytes(r[4])) for r in log.raw(["/a", "/b"])]
                return got, list(log.notes)
    except LogError as err:
        return str(err)


IN_ORDER = [1000 * (k // 2) for k in range(300)]  # pairs at equal times
SHUFFLED = [1000 * ((k * 37) % 300) for k in range(300)]  # every chunk spans most of the log
RUNS = [1000 * (k // 10) for k in range(300)]  # a chunk often ends at the next one's start time


@pytest.mark.parametrize(("times", "chunked", "compression"), [
    (IN_ORDER, True, CompressionType.ZSTD), (IN_ORDER, True, CompressionType.NONE),
    (SHUFFLED, True, CompressionType.LZ4), (RUNS, True, CompressionType.ZSTD),
    (IN_ORDER, False, CompressionType.NONE), (SHUFFLED, False, CompressionType.NONE)],
    ids=["chunks", "plain-chunks", "overlapping", "touching", "unchunked", "unchunked-unordered"])
def test_same_as_rosbags_healthy_and_damaged(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             times: list[int], chunked: bool,
                                             compression: CompressionType) -> None:
    path = _write(tmp_path / "log.mcap", times, chunked, compression)
    with open_log(path) as log:  # the fast path is taken
        source = log._source._reader  # type: ignore[attr-defined]
        assert mcapfast.messages(source, source.connections) is not None
    healthy = _read(path, True, monkeypatch)
    assert healthy == _read(path, False, monkeypatch)
    if times is not SHUFFLED:
        assert [m[2] for m in healthy[0]] == times and healthy[1] == []
    data = path.read_bytes()
    for pos in range(8, len(data) - 8, max(1, len(data) // 120)):  # a byte changed
        damaged = tmp_path / f"d{pos}.mcap"
        damaged.write_bytes(data[:pos] + bytes([data[pos] ^ 0x5A]) + data[pos + 1:])
        assert _read(damaged, True, monkeypatch) == _read(damaged, False, monkeypatch), pos
        damaged.unlink()


def test_a_rosbag2_folder_is_read_fast(tmp_path: Path) -> None:
    """A rosbag2 folder with one MCAP file goes through the fast path, mapped to its topics."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    string = store.types["std_msgs/msg/String"]
    with BagWriter(tmp_path / "bag", version=8, storage_plugin=StoragePlugin.MCAP) as w:
        conns = [w.add_connection(t, "std_msgs/msg/String", typestore=store) for t in ("/b", "/a")]
        for k in range(50):
            w.write(conns[k % 2], 10 * k, store.serialize_cdr(string(data=str(k)),
                                                               "std_msgs/msg/String"))
    with open_log(tmp_path / "bag") as log:
        source = log._source._reader  # type: ignore[attr-defined]
        fast = mcapfast.messages(source, source.connections)
        assert fast is not None
        assert [(c.topic, t, d) for c, t, d in fast] == [
            (c.topic, t, d) for c, t, d in source.messages()]
