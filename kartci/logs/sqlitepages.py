"""The rows of an sqlite3 file read page by page, without its schema or b-tree, as sqlite's
`.recover` does.

When page 1 (the schema), a table's root or an interior page is damaged, sqlite's SQL
interface reaches nothing, though the rows still sit in intact leaf pages. Python's sqlite3
module has neither the recovery extension nor the `sqlite_dbpage` table, so every page is
parsed here as https://www.sqlite.org/fileformat2.html describes it: a table b-tree leaf page
(type 0x0D) holds a cell pointer array; a cell is a varint payload length, a varint rowid and a
record (a header of serial types, then the values), its tail chained through overflow pages
when it does not fit. Which table a row belongs to is left to the caller (by its shape).
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass

MAGIC = b"SQLite format 3\x00"
_LEAF = 0x0D
_SIZES = tuple(1 << k for k in range(9, 17))  # every legal page size, 512 B .. 64 KiB

Value = int | float | str | bytes | None


@dataclass(frozen=True)
class Cell:
    """One row of a table b-tree leaf: its types (serial types) come from the record header
    at the start of the payload; `values` is None when the payload cannot be read whole
    (its overflow chain is broken, or the record does not hold together)."""

    page: int
    rowid: int
    types: tuple[int, ...]
    values: tuple[Value, ...] | None


def varint(data: bytes, pos: int) -> tuple[int, int]:
    """sqlite's big-endian varint at `pos`: (value, position after it); 1-9 bytes."""
    value = 0
    for i in range(8):
        byte = data[pos + i]
        value = (value << 7) | (byte & 0x7F)
        if byte < 0x80:
            return value, pos + i + 1
    return (value << 8) | data[pos + 8], pos + 9


def _width(serial: int) -> int:
    """The bytes a value of this serial type takes in a record."""
    if serial >= 12:
        return (serial - 12) // 2
    return (0, 1, 2, 3, 4, 6, 8, 8, 0, 0, 0, 0)[serial]


def record_types(payload: bytes) -> tuple[tuple[int, ...], int]:
    """The serial types of a record's header and where its body starts (IndexError or
    ValueError when the header does not hold together)."""
    size, pos = varint(payload, 0)
    if not 0 < size <= len(payload):
        raise ValueError("record header size")
    types: list[int] = []
    while pos < size:
        serial, pos = varint(payload, pos)
        if serial in (10, 11):
            raise ValueError("reserved serial type")
        types.append(serial)
    return tuple(types), size


def _value(serial: int, raw: bytes) -> Value:
    if serial == 0:
        return None
    if serial in (8, 9):
        return serial - 8
    if serial == 7:
        return float(struct.unpack(">d", raw)[0])
    if serial < 7:
        return int.from_bytes(raw, "big", signed=True)
    return raw if serial % 2 == 0 else raw.decode("utf-8", errors="replace")


def record_values(payload: bytes, types: tuple[int, ...], start: int) -> tuple[Value, ...]:
    """A record's values; ValueError when its body is not exactly as long as its types say."""
    widths = [_width(t) for t in types]
    if start + sum(widths) != len(payload):
        raise ValueError("record body length")
    values: list[Value] = []
    for serial, width in zip(types, widths, strict=True):
        values.append(_value(serial, payload[start:start + width]))
        start += width
    return tuple(values)


@dataclass(frozen=True)
class Pages:
    """A database image cut into pages of `size` bytes; `usable` excludes reserved bytes."""

    data: bytes
    size: int
    usable: int

    @property
    def count(self) -> int:
        return len(self.data) // self.size

    def page(self, number: int) -> bytes:
        """Page `number` (1-based); the header of page 1 is part of it."""
        return self.data[(number - 1) * self.size:number * self.size]

    def local(self, total: int) -> int:
        """How many of a table leaf cell's `total` payload bytes sit on the leaf page."""
        u = self.usable
        if total <= u - 35:
            return total
        m = (u - 12) * 32 // 255 - 23
        k = m + (total - m) % (u - 4)
        return k if k <= u - 35 else m

    def payload(self, page: bytes, pos: int, total: int) -> tuple[bytes, bool]:
        """A cell's payload starting at `pos` of `page`, following its overflow chain;
        (what could be read, whether it is whole)."""
        here = self.local(total)
        parts, have = [page[pos:pos + here]], here
        if here < total <= len(self.data):  # a damaged length claims more than the file
            (nxt,) = struct.unpack_from(">I", page, pos + here)
            seen: set[int] = set()
            while have < total and 0 < nxt <= self.count and nxt not in seen:
                seen.add(nxt)
                over = self.page(nxt)
                chunk = over[4:4 + min(total - have, self.usable - 4)]
                parts.append(chunk)
                have += len(chunk)
                (nxt,) = struct.unpack_from(">I", over, 0)
        data = b"".join(parts)
        return data, len(data) == total

    def cells(self, number: int) -> Iterator[Cell]:
        """The cells of page `number` if it is a table b-tree leaf; a malformed cell is
        skipped, one whose record header is readable but whose rest is not has no values."""
        page = self.page(number)
        head = 100 if number == 1 else 0
        if len(page) < head + 8 or page[head] != _LEAF:
            return
        (n,) = struct.unpack_from(">H", page, head + 3)
        if head + 8 + 2 * n > self.usable:
            return
        for i in range(n):
            (at,) = struct.unpack_from(">H", page, head + 8 + 2 * i)
            cell = self._cell(number, page, at)
            if cell is not None:
                yield cell

    def _cell(self, number: int, page: bytes, at: int) -> Cell | None:
        try:
            total, pos = varint(page, at)
            rowid, pos = varint(page, pos)
            data, whole = self.payload(page, pos, total)
            types, start = record_types(data)
            values = record_values(data, types, start) if whole else None
        except (IndexError, ValueError, struct.error):
            return None
        return Cell(number, rowid - (1 << 64) * (rowid >> 63), types, values)


def _leaf_ends_at(pages: Pages, number: int) -> bool:
    """Whether page `number` looks like a table leaf of exactly pages.size bytes: its cells
    are packed from the page's end, so the furthest one ends there (the page size test)."""
    page = pages.page(number)
    if len(page) < 8 or page[0] != _LEAF:
        return False
    try:
        (n,) = struct.unpack_from(">H", page, 3)
        ends = []
        for i in range(n):
            (at,) = struct.unpack_from(">H", page, 8 + 2 * i)
            total, pos = varint(page, at)
            _, pos = varint(page, pos)
            local = pages.local(total)
            ends.append(pos + local + (4 if local < total else 0))
    except (IndexError, struct.error):
        return False
    return bool(ends) and max(ends) == pages.size


def layout(data: bytes) -> Pages | None:
    """The page size from the file header; when the header is damaged, the size at which
    most pages (of the first 16 MiB) are whole table leaves. None: no page found."""
    if data[:16] == MAGIC:
        size = int.from_bytes(data[16:18], "big")
        size = 65536 if size == 1 else size
        if size in _SIZES:  # sqlite's usable size is at least 480 bytes
            return Pages(data, size, size - (data[20] if size - data[20] >= 480 else 0))
    sample = data[:1 << 24]
    best, most = None, 0
    for size in _SIZES:
        pages = Pages(sample, size, size)
        whole = sum(_leaf_ends_at(pages, n) for n in range(2, pages.count + 1))
        if whole > most:
            best, most = size, whole
    return None if best is None else Pages(data, best, best)


def table_rows(data: bytes) -> Iterator[Cell]:
    """Every cell of every table b-tree leaf page in `data` (a whole sqlite3 file or its
    readable start), in page order; nothing when no page size can be found."""
    pages = layout(data)
    if pages is None:
        return
    for number in range(1, pages.count + 1):
        yield from pages.cells(number)
