"""Issue 40, item 5: no hang. Every count a user gives is bounded by one cap (MAX_RUNS),
checked before any work; a file whose structure cannot be a log fails in seconds with one
line, however large it claims to be (the sparse files here cost no disk)."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

import kartci
from kartci.cli import app
from kartci.errors import LogError, SpecError
from kartci.logs import McapLogWriter
from kartci.logs.diff import diff_logs
from kartci.logs.salvage import MCAP_MAGIC
from kartci.logs.types import msg

GIB = 1 << 30
CAP = 10_000  # kartci.runner.jobs.MAX_RUNS
UNKNOWN_RUN_BYTES = 16 << 20  # kartci.logs.salvage.UNKNOWN_RUN_BYTES
# an MCAP Header record: opcode 0x01, length, then two empty strings (profile, library)
HEADER = b"\x01" + (8).to_bytes(8, "little") + bytes(8)


def _sparse(path: Path, head: bytes, n_bytes: int) -> Path:
    with path.open("wb") as f:
        f.write(head)
        f.truncate(n_bytes)  # the rest is a hole: no data blocks
    return path


def _good(path: Path) -> Path:
    with McapLogWriter(path) as out:
        out.write("/chatter", msg("std_msgs/msg/String", data="hi"), 1000)
    return path


def _cli(*args: str | Path) -> subprocess.CompletedProcess[str]:
    """The CLI with a wall-clock bound: on b96f9b4 these ran for minutes."""
    return subprocess.run([sys.executable, "-m", "kartci.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=60)


def test_diff_against_a_20_gib_sparse_file_after_the_mcap_magic_fails_in_seconds(
        tmp_path: Path) -> None:
    good = _good(tmp_path / "good.mcap")
    big = _sparse(tmp_path / "big.mcap", MCAP_MAGIC, 20 * GIB)
    start = time.monotonic()
    p = _cli("diff", good, big)
    assert time.monotonic() - start < 30
    assert p.returncode == 2
    lines = p.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"kartci: error: B: {big}: "), p.stderr
    assert "opcode 0x00, which no MCAP record has: not an MCAP log from here on" in lines[0]


@pytest.mark.parametrize("name", ["header_then_zeros", "unknown_records"])
def test_a_log_that_is_mostly_nothing_is_refused_without_reading_it_all(
        tmp_path: Path, name: str) -> None:
    """A valid Header followed by a hole; and records of an unknown type, 1 MiB each, more of
    them in a row than any log holds (the plain stream reader skipped them without end)."""
    path = tmp_path / f"{name}.mcap"
    if name == "header_then_zeros":
        _sparse(path, MCAP_MAGIC + HEADER, 20 * GIB)
        why = "opcode 0x00"
    else:
        record = 1 << 20
        with path.open("wb") as f:
            f.write(MCAP_MAGIC + HEADER)
            for _ in range(UNKNOWN_RUN_BYTES // record + 2):
                f.write(b"\x80" + record.to_bytes(8, "little"))
                f.seek(record, 1)
            f.truncate(20 * GIB)
        why = "of records of unknown type in a row: not an MCAP log from here on"
    start = time.monotonic()
    with pytest.raises(LogError, match=why):
        diff_logs(path, path)
    assert time.monotonic() - start < 20


def test_a_20_gib_sparse_sqlite_file_is_not_read_into_memory(tmp_path: Path) -> None:
    """On b96f9b4 the salvage read it whole (8 GB of memory after 60 s, still going)."""
    big = _sparse(tmp_path / "big.db3", b"SQLite format 3\0", 20 * GIB)
    p = _cli("recover", big, "-o", tmp_path / "r.mcap")
    assert p.returncode == 2
    assert "21,474,836,480 bytes, more than the 2 GiB a damaged sqlite3 file is read into " \
           "memory to salvage" in p.stderr
    assert len(p.stderr.splitlines()) == 1


def test_baseline_update_refuses_a_billion_replicas_before_any_work(tmp_path: Path) -> None:
    result = CliRunner().invoke(app, ["baseline", "update", str(tmp_path / "none"),
                                      "--replicas", "1000000000"])
    assert isinstance(result.exception, SpecError)
    assert str(result.exception) == "--replicas 1,000,000,000: more than the 10,000 allowed"


@pytest.mark.parametrize("option", ["--conditioning", "--repeat", "--jobs"])
def test_run_refuses_every_count_over_the_cap_before_any_work(tmp_path: Path,
                                                             option: str) -> None:
    result = CliRunner().invoke(app, ["run", "no_such_scenario", option, str(CAP + 1),
                                      "--out", str(tmp_path / "o")])
    assert isinstance(result.exception, SpecError)
    assert str(result.exception) == f"{option} 10,001: more than the 10,000 allowed"
    assert not (tmp_path / "o").exists()


def test_the_python_api_shares_the_cap(tmp_path: Path) -> None:
    with pytest.raises(SpecError, match=r"^--replicas 10,001: more than the 10,000 allowed$"):
        kartci.accept_baselines(tmp_path, replicas=CAP + 1)
