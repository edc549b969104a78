"""A truncated MCAP whose data is one compressed chunk (as rosbag2 and Foxglove write short
recordings): the chunk is stream-decompressed up to the cut, every complete message before it
is read, what was lost is counted, and `kartci recover` writes the salvaged log."""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import pytest
from helpers import kartci
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from kartci.logs import SalvagedLog, extract, messages, recover, topics


def _one_chunk(bags: Path, tmp: Path, compression: CompressionType) -> Path:
    """The TurtleBot3 bag's 10,527 messages (odometry, scans, IMU, joints, commands) as one
    MCAP chunk of about 5 MB."""
    src = bags / "turtlebot3_gazebo_cmd_odom_scan.bag"
    many = tmp / "chunks.mcap"
    extract(src, [i.topic for i in topics(src)], many)
    out = tmp / f"one_{compression.name.lower()}.mcap"
    with many.open("rb") as f, out.open("wb") as g:
        reader = make_reader(f)
        w = Writer(g, chunk_size=64 << 20, compression=compression)
        w.start(profile="ros2", library="test")
        ids: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages():
            if channel.id not in ids:
                assert schema is not None
                sid = w.register_schema(schema.name, schema.encoding, schema.data)
                ids[channel.id] = w.register_channel(channel.topic, "cdr", sid)
            w.add_message(ids[channel.id], log_time=message.log_time, data=message.data,
                          publish_time=message.publish_time, sequence=message.sequence)
        w.finish()  # type: ignore[no-untyped-call]
    with out.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and len(summary.chunk_indexes) == 1
    return out


def _read(path: Path) -> tuple[list[tuple[str, int]], list[str]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        got = [(topic, t) for topic, t, _ in messages(path)]
    return got, [str(w.message) for w in caught if issubclass(w.category, SalvagedLog)]


@pytest.mark.parametrize("compression", [CompressionType.ZSTD, CompressionType.LZ4],
                         ids=["zstd", "lz4"])
def test_a_single_chunk_mcap_cut_at_30_percent_yields_the_messages_before_the_cut(
        bags: Path, tmp_path: Path, compression: CompressionType) -> None:
    whole = _one_chunk(bags, tmp_path, compression)
    full, notes = _read(whole)
    assert len(full) == 10527 and notes == []
    data = whole.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.3)])
    got, notes = _read(cut)
    # every complete message before the cut, in the chunk's order: a prefix of the log
    # (up to the last whole compressed block; scans compress less than odometry)
    assert 0.2 * len(full) < len(got) < 0.5 * len(full)
    assert sorted(got, key=lambda m: m[1]) == sorted(full[: len(got)], key=lambda m: m[1])
    (note,) = notes
    found = re.search(r"(\d[\d,]*) messages recovered from it by stream decompression, about "
                      r"(\d[\d,]*) messages lost with its rest", note)
    assert found is not None, note
    recovered, lost = (int(x.replace(",", "")) for x in found.groups())
    assert recovered == len(got)
    assert lost == pytest.approx(len(full) - len(got), rel=0.1)  # an estimate from sizes

    out = tmp_path / "recovered.mcap"
    assert recover(cut, out) == len(got)
    again, notes = _read(out)
    assert again == sorted(got, key=lambda m: m[1]) and notes == []


@pytest.mark.long(reason="kartci runs end to end")
def test_recover_writes_the_salvaged_log_from_the_command_line(bags: Path,
                                                               tmp_path: Path) -> None:
    whole = _one_chunk(bags, tmp_path, CompressionType.ZSTD)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[: int(whole.stat().st_size * 0.6)])
    out = tmp_path / "recovered.mcap"
    r = kartci("recover", cut, "--out", out)
    assert r.returncode == 0, r.stderr
    n = int(r.stdout.split(": ")[1].split()[0])
    assert n == sum(1 for _ in messages(out)) and n > 0.5 * 10527
    assert "lost with its rest" in r.stderr
    nothing = tmp_path / "nothing.mcap"
    nothing.write_bytes(whole.read_bytes()[:200])
    r = kartci("recover", nothing, "--out", tmp_path / "x.mcap")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (tmp_path / "x.mcap").exists()
