"""A rosbag2 .db3 whose schema page, topics table, an interior, a leaf or an overflow page is
damaged, or which is cut short, gives back exactly the message rows still whole in its leaf
pages (page by page, as sqlite's .recover does), each the same bytes as the intact read and
in its order, with the count lost; nothing recoverable is one line, exit 2.

Which rows each damage must leave is worked out from sqlite's own `dbstat` table on the
intact file (the pages of each table, the leaves in key order, each cell's overflow pages),
not from the scanner under test."""

from __future__ import annotations

import shutil
import sqlite3
import warnings
from dataclasses import dataclass
from pathlib import Path

import pytest
from helpers import kartci
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from kartci.errors import LogError
from kartci.logs import SalvagedLog, open_log
from kartci.logs.salvage import salvage

N = 300
STORE = get_typestore(Stores.ROS2_HUMBLE)
Msg = tuple[str, int, bytes]  # topic, log time ns, CDR bytes


def _message(k: int) -> Msg:
    """Every 10th message is 9 KB (two overflow pages of 4 KB); time runs backwards in pairs,
    so the reader's order (time, then id) differs from the rows' order."""
    text = f"m{k} " + ("y" * 9000 if k % 10 == 0 else "z" * 100)
    data = bytes(STORE.serialize_cdr(STORE.types["std_msgs/msg/String"](data=text),
                                     "std_msgs/msg/String"))
    return ("/big" if k % 10 == 0 else "/chatter"), 10**9 + (N - 1 - k) // 2 * 10**7, data


@pytest.fixture(scope="module")
def written(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("db3") / "bag"
    with Writer(path, version=8, storage_plugin=StoragePlugin.SQLITE3) as w:
        conns = {t: w.add_connection(t, "std_msgs/msg/String", typestore=STORE)
                 for t in ("/chatter", "/big")}
        for k in range(N):
            topic, t_ns, data = _message(k)
            w.write(conns[topic], t_ns, data)
    return path


@dataclass(frozen=True)
class Layout:
    """Where the intact file keeps what (sqlite's dbstat): page numbers, and per message id
    its leaf and overflow pages."""

    roots: dict[str, int]
    interior: list[int]
    leaf_of: dict[int, int]
    overflow_of: dict[int, list[int]]
    pages: int


def _layout(db3: Path) -> Layout:
    con = sqlite3.connect(db3)
    roots = dict(con.execute("SELECT name, rootpage FROM sqlite_master"))
    rows = con.execute("SELECT path, pageno, pagetype, ncell FROM dbstat WHERE name = "
                       "'messages' ORDER BY path").fetchall()
    interior = [n for _, n, kind, _ in rows if kind == "internal"]
    leaf_of: dict[int, int] = {}
    first: dict[str, int] = {}  # a leaf's path -> its first message id (ids run in key order)
    for path, number, kind, ncell in rows:
        if kind == "leaf":
            first[path] = len(leaf_of) + 1
            leaf_of.update({len(leaf_of) + 1 + i: number for i in range(ncell)})
    overflow_of: dict[int, list[int]] = {}
    for path, number, kind, _ in rows:
        if kind == "overflow":  # "<leaf path><cell, hex>+<link>"
            leaf, cell = path[:path.rindex("/") + 1], int(path.rsplit("/", 1)[1][:3], 16)
            overflow_of.setdefault(first[leaf] + cell, []).append(number)
    (pages,) = con.execute("PRAGMA page_count").fetchone()
    return Layout(roots, interior, leaf_of, overflow_of, pages)


def _damage(good: Path, tmp: Path, zero: list[int], cut: int | None = None) -> Path:
    """A copy of a rosbag2 folder with pages `zero` (4 KB, 1-based) zeroed, cut at `cut`."""
    path = tmp / "damaged"
    shutil.copytree(good, path)
    (db3,) = path.glob("*.db3")
    data = bytearray(db3.read_bytes())
    size = int.from_bytes(data[16:18], "big")
    for n in zero:
        data[(n - 1) * size:n * size] = bytes(size)
    db3.write_bytes(bytes(data[:cut]))
    return path


def _read(path: Path) -> tuple[list[Msg], list[str]]:
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        with open_log(path) as log:
            got = [(topic, t, data) for topic, _, _, t, data in log.raw()]
    return got, [str(w.message) for w in seen if issubclass(w.category, SalvagedLog)]


def _kept(ids: set[int]) -> list[Msg]:
    """The messages of these ids (1-based), in the reader's order: time, then id."""
    return [m for _, m in sorted(((_message(i - 1)[1], i), _message(i - 1)) for i in ids)]


def test_the_intact_file_reads_in_time_then_id_order(written: Path) -> None:
    got, notes = _read(written)
    assert got == _kept(set(range(1, N + 1))) and notes == []


def _cases(lay: Layout, size: int) -> dict[str, tuple[list[int], int | None, set[int], int]]:
    """name -> (pages zeroed, cut, message ids that must come back, rows with a broken
    overflow chain)."""
    every = set(lay.leaf_of)
    leaf = sorted(set(lay.leaf_of.values()))[len(set(lay.leaf_of.values())) // 2]
    big = sorted(lay.overflow_of)[3]
    whole = int(size * 0.7) // 4096  # the pages a 70 % cut leaves whole
    beyond = {i for i, pages in lay.overflow_of.items() if max(pages) > whole}
    return {
        "page_1": ([1], None, every, 0),
        "interior": (lay.interior, None, every, 0),
        "leaf": ([leaf], None, {i for i in every if lay.leaf_of[i] != leaf}, 0),
        "overflow": ([lay.overflow_of[big][0]], None, every - {big}, 1),
        "cut_70": ([], int(size * 0.7),
                   {i for i in every if lay.leaf_of[i] <= whole} - beyond,
                   len({i for i in beyond if lay.leaf_of[i] <= whole})),
    }


@pytest.mark.parametrize("case", ["page_1", "interior", "leaf", "overflow", "cut_70"])
def test_exactly_the_rows_in_whole_leaf_pages_come_back(written: Path, tmp_path: Path,
                                                        case: str) -> None:
    (db3,) = written.glob("*.db3")
    lay = _layout(db3)
    assert lay.interior and len(lay.overflow_of) == N // 10  # the layout the cases need
    zero, cut, ids, broken = _cases(lay, db3.stat().st_size)[case]
    got, notes = _read(_damage(written, tmp_path, zero, cut))
    assert got == _kept(ids)
    (note,) = notes
    assert "\n" not in note and "read page by page, as sqlite's .recover does: " in note
    lost = f"{N - len(ids)} messages of {N} lost" if N - len(ids) != 1 else f"1 message of {N} lost"
    assert f"{len(ids)} messages read page by page, {lost}" in note
    assert (f"({broken} row{'s' * (broken != 1)} with a broken overflow chain)" in note) == (
        broken > 0)
    print(f"{case}: {len(ids)} of {N} recovered, {broken} broken chains")


def test_a_destroyed_topics_table_is_one_line_that_counts_the_orphans(written: Path,
                                                                      tmp_path: Path) -> None:
    (db3,) = written.glob("*.db3")
    damaged = _damage(written, tmp_path, [_layout(db3).roots["topics"]])
    with pytest.raises(LogError, match=f"{N} messages of {N} lost \\({N} rows of a topic "
                                       "whose row is lost\\)"):
        _read(damaged)
    r = kartci("recover", damaged, "--out", tmp_path / "out.mcap")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert not (tmp_path / "out.mcap").exists()


def test_recover_writes_what_the_pages_hold(written: Path, tmp_path: Path) -> None:
    r = kartci("recover", _damage(written, tmp_path, [1]), "--out", tmp_path / "out.mcap")
    assert r.returncode == 0, r.stderr
    assert r.stdout.endswith(f"out.mcap: {N} messages\n")
    assert r.stderr.count("\n") == 1 and "as sqlite's .recover does" in r.stderr
    got, notes = _read(tmp_path / "out.mcap")
    assert got == _kept(set(range(1, N + 1))) and notes == []


@pytest.mark.parametrize("data", [bytes(3 * 4096), b"SQLite format 3\x00" + bytes(4080)],
                         ids=["zeros", "header_only"])
def test_a_file_with_no_recoverable_row_is_one_line(tmp_path: Path, data: bytes) -> None:
    (tmp_path / "x.db3").write_bytes(data)
    r = kartci("recover", tmp_path / "x.db3", "--out", tmp_path / "out.mcap")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.count("\n") == 1 and r.stderr.startswith("kartci: error: ")


def test_rosbag2s_own_test_bag(bags: Path, tmp_path: Path) -> None:
    """rosbag2's cdr_test bag (7 messages in one leaf, page 6; topics on page 4): with page
    1 zeroed every message comes back, the same bytes; with its topics or its one message
    leaf zeroed, or cut at 70 % (before the messages' page), nothing can, in one line."""
    good = bags / "rosbag2_cdr_test_db3"
    intact, _ = _read(good)
    got, notes = _read(_damage(good, tmp_path / "p1", [1]))
    assert got == intact and len(got) == 7
    assert "7 messages read page by page, 0 messages of 7 lost" in notes[0]
    for name, zero, cut in (("topics", [4], None), ("leaf", [6], None), ("cut", [], 20070)):
        r = kartci("recover", _damage(good, tmp_path / name, zero, cut), "--out",
                   tmp_path / f"{name}.mcap")
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert r.stderr.count("\n") == 1 and "7 messages of 7 lost" in r.stderr, r.stderr


def test_any_byte_damaged_never_raises(written: Path, tmp_path: Path) -> None:
    """Each of 150 bytes spread over the file (headers, pointers, varints, overflow links)
    set to 0xFF and to 0x00 in turn: the salvage reads something or nothing, never raises."""
    (db3,) = written.glob("*.db3")
    data = db3.read_bytes()
    for at in range(7, len(data), len(data) // 150):
        for byte in (b"\xff", b"\x00"):
            (tmp_path / "x.db3").write_bytes(data[:at] + byte + data[at + 1:])
            found = salvage(tmp_path / "x.db3")
            assert len(found.found) <= N
