"""The page scanner reads every row sqlite itself reads, with every type of value, at every
page size, overflow pages included; with page 1 zeroed the page size is found from the
leaves; a broken overflow chain gives the row without values."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from kartci.logs.sqlitepages import Cell, layout, table_rows, varint

VALUES: list[object] = [None, 0, 1, -1, 127, -129, 40_000, -(2**23), 2**31, -(2**47), 2**62,
                        -(2**63), 2.5, float("-inf"), "", "ü" * 7, b"", b"\x00\xff" * 3]


def _db(path: Path, page: int, big: int) -> Path:
    """A table holding every kind of value, and rows of `big`-byte blobs (overflow pages)."""
    con = sqlite3.connect(path)
    con.execute(f"PRAGMA page_size={page}")
    con.execute("CREATE TABLE t(id INTEGER PRIMARY KEY, a, b BLOB)")
    con.executemany("INSERT INTO t(a, b) VALUES (?, ?)", [(v, b"") for v in VALUES])
    con.executemany("INSERT INTO t(a, b) VALUES (?, ?)",
                    [(k, bytes([k]) * (big + k)) for k in range(40)])
    con.commit()
    con.close()
    return path


def _rows(cells: list[Cell]) -> dict[int, tuple[object, ...]]:
    return {c.rowid: c.values[1:] for c in cells if c.values is not None and len(c.types) == 3}


@pytest.mark.parametrize("page", [512, 4096, 65536])
def test_every_row_is_read_as_sqlite_reads_it(tmp_path: Path, page: int) -> None:
    db = _db(tmp_path / "t.db", page, 3 * page)
    want = {rid: (a, b) for rid, a, b in sqlite3.connect(db).execute("SELECT id, a, b FROM t")}
    data = db.read_bytes()
    assert _rows(list(table_rows(data))) == want
    zeroed = bytes(page) + data[page:]  # the header and schema gone: the size is found again
    pages = layout(zeroed)
    assert pages is not None and pages.size == page
    assert _rows(list(table_rows(zeroed))) == want


@pytest.mark.parametrize("link", [0, 2])
def test_a_broken_overflow_chain_leaves_the_row_without_values(tmp_path: Path,
                                                                link: int) -> None:
    """One overflow page zeroed (the first or the third of a row's four): that row alone
    comes back without values, every other row as sqlite reads it. (A zeroed last page of a
    chain cannot be told from data that is zeros: sqlite reads it as such, and so does this.)"""
    db = _db(tmp_path / "t.db", 1024, 5000)
    con = sqlite3.connect(db)
    want = {rid: (a, b) for rid, a, b in con.execute("SELECT id, a, b FROM t")}
    (number,) = con.execute("SELECT pageno FROM dbstat WHERE pagetype = 'overflow' AND path "
                            "LIKE ? LIMIT 1 OFFSET 5", (f"%+{link:06x}",)).fetchone()
    data = db.read_bytes()
    data = data[:(number - 1) * 1024] + bytes(1024) + data[number * 1024:]
    cells = list(table_rows(data))
    (broken,) = [c for c in cells if c.values is None]
    assert broken.types[2] == 12 + 2 * len(want[broken.rowid][1])  # its record header is read
    assert _rows(cells) == {rid: v for rid, v in want.items() if rid != broken.rowid}


def test_varints_of_one_to_nine_bytes() -> None:
    assert varint(b"\x7f", 0) == (127, 1)
    assert varint(b"\x81\x00", 0) == (128, 2)
    assert varint(b"\xff" * 9, 0) == (2**64 - 1, 9)


def test_no_page_found_in_bytes_that_are_no_database() -> None:
    assert layout(bytes(8192)) is None
    assert list(table_rows(b"not a database" * 100)) == []
