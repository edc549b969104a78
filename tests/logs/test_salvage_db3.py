"""A damaged rosbag2 sqlite3 (.db3) file: sqlite reads it up to the damage, then every
message row still whole in a leaf page is read page by page (as sqlite's .recover does), intact,
with the count lost from metadata.yaml, in one warning line; `kartci recover` writes them;
nothing readable is one error line, never a traceback (test_salvage_db3_pages.py: exactly
which rows each kind of damage leaves)."""

from __future__ import annotations

import re
import shutil
import warnings
from pathlib import Path

import pytest
from helpers import kartci
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from kartci.logs import SalvagedLog, messages, open_log

N = 2000
STORE = get_typestore(Stores.ROS2_HUMBLE)


def _text(k: int) -> str:
    return f"message {k} " + "x" * 300  # about 11 rows a 4 KB page


@pytest.fixture(scope="module")
def good(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A rosbag2 sqlite3 folder written by rosbags: N std_msgs/String, 10 ms apart."""
    path = tmp_path_factory.mktemp("db3") / "talk"
    with Writer(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        c = w.add_connection("/chatter", "std_msgs/msg/String", typestore=STORE)
        for k in range(N):
            m = STORE.types["std_msgs/msg/String"](data=_text(k))
            w.write(c, 10**9 + k * 10**7, STORE.serialize_cdr(m, "std_msgs/msg/String"))
    return path


def _damaged(good: Path, tmp: Path, at: float, zero: int | None) -> Path:
    """A copy of `good` cut at `at` of its .db3 (zero=None), or with `zero` bytes zeroed there."""
    path = tmp / "damaged"
    shutil.copytree(good, path)
    (db3,) = path.glob("*.db3")
    data = db3.read_bytes()
    cut = int(len(data) * at)
    db3.write_bytes(data[:cut] if zero is None else data[:cut] + bytes(zero) + data[cut + zero:])
    return path


def _read(path: Path) -> tuple[list[tuple[int, str]], list[str]]:
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        got = [(t, m.data) for _, t, m in messages(path)]
    return got, [str(w.message) for w in seen if issubclass(w.category, SalvagedLog)]


@pytest.mark.parametrize(("at", "zero"), [(0.3, None), (0.6, None), (0.5, 4096)],
                         ids=["cut_30", "cut_60", "zeroed_page"])
def test_every_intact_row_is_read_and_the_loss_counted(good: Path, tmp_path: Path, at: float,
                                                       zero: int | None) -> None:
    got, notes = _read(_damaged(good, tmp_path, at, zero))
    assert got, "nothing salvaged"
    for t, text in got:  # each message intact, at its own time
        k = (t - 10**9) // 10**7
        assert text == _text(k)
    ks = [(t - 10**9) // 10**7 for t, _ in got]
    assert ks == sorted(set(ks))
    (note,) = notes
    assert "\n" not in note
    lost = re.search(r"(\d+) messages? of 2000 lost", note)
    assert lost is not None, note
    assert len(got) + int(lost.group(1)) == N
    assert f"read page by page, as sqlite's .recover does: {len(got)} messages on 1 topic" in note
    if zero is None:  # a cut: what is read comes before it, and most of what came before
        assert max(ks) < at * N and len(got) > 0.7 * at * N
    else:  # one zeroed page: about its rows lost, those after it read from the end
        assert max(ks) == N - 1 and N - len(got) < 40


def test_recover_writes_the_rows_a_damaged_db3_still_has(good: Path, tmp_path: Path) -> None:
    log = _damaged(good, tmp_path, 0.5, 4096)
    r = kartci("recover", log, "--out", tmp_path / "saved.mcap")
    assert r.returncode == 0, r.stderr
    wrote = re.fullmatch(r"wrote .*saved\.mcap: (\d+) messages\n", r.stdout)
    assert wrote is not None, r.stdout
    n = int(wrote.group(1))
    assert N - 40 < n < N
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert re.search(r"damaged after message row \d+: \d+ messages read page by page, \d+ "
                     r"messages of 2000 lost", r.stderr)
    with open_log(tmp_path / "saved.mcap") as saved:
        assert [i.count for i in saved.topics()] == [n]


def test_a_db3_without_its_header_and_schema_is_read_page_by_page(good: Path,
                                                                  tmp_path: Path) -> None:
    log = _damaged(good, tmp_path, 0.0, 200)  # the file header and schema gone
    r = kartci("recover", log, "--out", tmp_path / "saved.mcap")
    assert r.returncode == 0 and r.stdout.endswith(f"saved.mcap: {N} messages\n"), r.stderr
    assert r.stderr.count("\n") == 1 and "does not open" in r.stderr
    assert f"{N} messages read page by page, 0 messages of {N} lost" in r.stderr


def test_the_shared_fixtures_db3_cut_short_is_one_line(bags: Path, tmp_path: Path) -> None:
    """rosbag2's own test bag (test_msgs types, 7 messages), cut at each quarter and inside
    its first page (the long fuzz found the image of no whole page a MemoryError in sqlite)."""
    for at in (0.125, 0.25, 0.5, 0.75, 0.95):
        log = _damaged(bags / "rosbag2_cdr_test_db3", tmp_path / str(at), at, None)
        r = kartci("recover", log, "--out", tmp_path / f"{at}.mcap")
        assert r.returncode in (0, 2), r.stderr
        assert "Traceback" not in r.stderr and "internal error" not in r.stderr
        lines = r.stderr.splitlines()
        assert lines and all(line.startswith("kartci: ") for line in lines), r.stderr
        if r.returncode == 0:  # read + lost = the 7 metadata.yaml lists
            (line,) = lines
            read = re.search(r"sqlite tables: (\d+) messages", line)
            lost = re.search(r"(\d+) messages? of 7 lost", line)
            assert read is not None, line
            assert int(read.group(1)) + (int(lost.group(1)) if lost else 0) == 7, line
