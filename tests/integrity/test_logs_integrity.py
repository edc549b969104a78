"""Issue 24, logs: `kartci extract` of a bit-flipped MCAP wrote 0 messages and exited 0 (defect
7; issue 28 asks the same of any log that yields no message). Now it exits 2 with one line
saying why, and leaves the output path as it was."""

from __future__ import annotations

from pathlib import Path

import pytest
from helpers import ROOT, kartci
from mcap.reader import make_reader

SHIPPED = ROOT / "scenarios" / "logs" / "kart_manual_ps4.mcap"
FIXTURES = ROOT.parent / "shared" / "fixtures" / "bags"
DAMAGED = "0 messages on 1 topic; 1 damaged chunk not fully read"


def _bit_flipped(src: Path, dst: Path) -> None:
    """`src` with one bit flipped in the middle of its first chunk (compressed data)."""
    with src.open("rb") as f:
        chunk = make_reader(f).get_summary().chunk_indexes[0]  # type: ignore[union-attr]
    data = bytearray(src.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length // 2] ^= 0x10
    dst.write_bytes(bytes(data))


@pytest.mark.parametrize(("source", "topic", "why"), [
    (SHIPPED, "/kart0/joy", DAMAGED),
    (FIXTURES / "cmd_vel_twiststamped.mcap", "/vehicle/cmd_vel", DAMAGED),
    (FIXTURES / "rosbag2_talker_mcap", "/parameter_events", "the log holds none on this topic"),
], ids=["bit-flipped-run-log", "bit-flipped-foreign-mcap", "topic-without-messages"])
def test_extract_of_nothing_exits_2(tmp_path: Path, source: Path, topic: str, why: str) -> None:
    if not source.exists():
        pytest.skip(f"{source} absent (../shared/fixtures is not part of a fresh clone)")
    log = source
    if source.suffix == ".mcap":
        log = tmp_path / "flipped.mcap"
        _bit_flipped(source, log)
    out = tmp_path / "out.mcap"
    out.write_bytes(b"an earlier extract")
    proc = kartci("extract", log, "--topic", topic, "--out", out, cwd=tmp_path)
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(f"kartci: error: {log}: no message of {topic} could be read (")
    assert why in lines[0] and lines[0].endswith(f"; nothing written to {out}")
    assert "wrote" not in proc.stdout
    assert out.read_bytes() == b"an earlier extract"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no partial
