"""Copy the readable rows out of a damaged session store, page by page (stdlib only).

SQLite refuses a whole query when one page on its way is damaged, so a store with a
truncated tail, a garbage header or one garbage page answered nothing and every session was
lost (issue 35 item 7: 40 of 40 in each case). :func:`salvage` reads the file as the SQLite
file format describes it (https://www.sqlite.org/fileformat2.html), without SQLite: every
page that is a table leaf is decoded on its own (its cells, their records, their overflow
chains), so a damaged page loses the rows on it and nothing else. The committed pages of a
``-wal`` file next to it are laid over the file's own (the newest committed frame of each
page), and pages on the freelist are skipped when the header says which they are. It is
what ``sqlite3``'s ``.recover`` does, for the three tables of the store; the SQLite command
line tool is not needed.

Rows are recognised by their shape (a ``sessions`` row: a code and two times, then the
teacher flag, version and config; a ``blobs`` row: code, part name, bytes; a
``class_state`` row: two texts). Nothing here is executed: the rows go back into a fresh
store, whose loading checks every part again (:meth:`app.services.storage.store.SessionStore.load`).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["Salvage", "salvage"]

_MAGIC = b"SQLite format 3\x00"
_PAGE_SIZES = (4096, 1024, 2048, 8192, 16384, 32768, 65536, 512)
_LEAF_TABLE = 13
_BLOB_KINDS = ("recording", "diagnosis")


@dataclass
class Salvage:
    """The rows read out of a damaged store.

    Attributes
    ----------
    sessions : dict
        ``code -> row`` of the ``sessions`` table, 11 values (``owner`` ``""`` when the
        file had none); the highest version when a code appears twice.
    blobs : dict
        ``(code, kind) -> bytes`` of the ``blobs`` table.
    class_state : dict
        ``key -> value`` of the ``class_state`` table.
    pages : int
        Pages read.
    damaged_pages : int
        Table pages that could not be decoded (and cells lost in them).
    """

    sessions: dict[str, tuple[Any, ...]] = field(default_factory=dict)
    blobs: dict[tuple[str, str], bytes] = field(default_factory=dict)
    class_state: dict[str, str] = field(default_factory=dict)
    pages: int = 0
    damaged_pages: int = 0


class _Bad(Exception):
    """A page or record that does not decode."""


def _varint(buf: bytes, i: int) -> tuple[int, int]:
    v = 0
    for k in range(9):
        if i + k >= len(buf):
            raise _Bad("varint past the end")
        b = buf[i + k]
        if k == 8:
            return (v << 8) | b, i + 9
        v = (v << 7) | (b & 0x7F)
        if b < 0x80:
            return v, i + k + 1
    raise _Bad("varint")  # pragma: no cover - the loop returns


def _value(serial: int, data: bytes, i: int) -> tuple[Any, int]:
    if serial == 0:
        return None, i
    if serial in (8, 9):
        return serial - 8, i
    if 1 <= serial <= 6:
        n = (1, 2, 3, 4, 6, 8)[serial - 1]
        if i + n > len(data):
            raise _Bad("integer past the end")
        return int.from_bytes(data[i:i + n], "big", signed=True), i + n
    if serial == 7:
        if i + 8 > len(data):
            raise _Bad("float past the end")
        return struct.unpack(">d", data[i:i + 8])[0], i + 8
    if serial >= 12:
        n = (serial - 12) // 2
        if i + n > len(data):
            raise _Bad("text or blob past the end")
        raw = data[i:i + n]
        if serial % 2:
            try:
                return raw.decode("utf-8"), i + n
            except UnicodeDecodeError:
                raise _Bad("text that is not UTF-8") from None
        return bytes(raw), i + n
    raise _Bad(f"serial type {serial}")


def _record(payload: bytes) -> tuple[Any, ...]:
    size, i = _varint(payload, 0)
    if not 1 <= size <= len(payload):
        raise _Bad("record header size")
    serials = []
    while i < size:
        s, i = _varint(payload, i)
        serials.append(s)
    values = []
    j = size
    for s in serials:
        v, j = _value(s, payload, j)
        values.append(v)
    return tuple(values)


class _File:
    """The pages of a database file, with the committed pages of its WAL laid over."""

    def __init__(self, data: bytes, wal: bytes | None) -> None:
        self.data = data
        header_ok = data[:16] == _MAGIC
        size = int.from_bytes(data[16:18], "big") if header_ok else 0
        size = 65536 if size == 1 else size
        wal_size = int.from_bytes(wal[8:12], "big") if wal and len(wal) >= 32 else 0
        self.page_size = (size if size in _PAGE_SIZES else
                          wal_size if wal_size in _PAGE_SIZES else self._guess())
        reserved = data[20] if header_ok and len(data) > 20 else 0
        self.usable = self.page_size - reserved
        self.overlay: dict[int, bytes] = self._wal(wal) if wal else {}
        n_file = len(data) // self.page_size
        self.count = max([n_file, *self.overlay])
        self.free = self._freelist() if header_ok else set()

    def _guess(self) -> int:
        """The page size that makes the most pages look like b-tree pages."""
        def score(size: int) -> int:
            return sum(1 for k in range(1, min(len(self.data) // size, 200))
                       if self.data[k * size] in (2, 5, 10, 13))
        return max(_PAGE_SIZES, key=score)

    def _wal(self, wal: bytes) -> dict[int, bytes]:
        if len(wal) < 32 or int.from_bytes(wal[0:4], "big") not in (0x377F0682, 0x377F0683):
            return {}
        size = int.from_bytes(wal[8:12], "big")
        if size != self.page_size:
            return {}
        salt = wal[16:24]
        pages: dict[int, bytes] = {}
        pending: dict[int, bytes] = {}
        off = 32
        while off + 24 + size <= len(wal):
            head = wal[off:off + 24]
            if head[8:16] != salt:
                break  # frames of an older generation of the log
            number = int.from_bytes(head[0:4], "big")
            pending[number] = wal[off + 24:off + 24 + size]
            if int.from_bytes(head[4:8], "big"):  # a commit frame: its transaction counts
                pages.update(pending)
                pending = {}
            off += 24 + size
        return pages

    def page(self, number: int) -> bytes | None:
        if number in self.overlay:
            return self.overlay[number]
        start = (number - 1) * self.page_size
        chunk = self.data[start:start + self.page_size]
        return chunk if len(chunk) == self.page_size else None

    def _freelist(self) -> set[int]:
        free: set[int] = set()
        trunk = int.from_bytes(self.data[32:36], "big")
        while trunk and trunk not in free and len(free) <= self.count:
            free.add(trunk)
            page = self.page(trunk)
            if page is None:
                break
            leaves = int.from_bytes(page[4:8], "big")
            for k in range(min(leaves, (self.usable - 8) // 4)):
                free.add(int.from_bytes(page[8 + 4 * k:12 + 4 * k], "big"))
            trunk = int.from_bytes(page[0:4], "big")
        return free

    def payload(self, page: bytes, off: int) -> tuple[bytes, int]:
        """The payload of the table-leaf cell at ``off`` and its rowid."""
        total, i = _varint(page, off)
        rowid, i = _varint(page, i)
        u = self.usable
        max_local = u - 35
        if total <= max_local:
            if i + total > len(page):
                raise _Bad("cell past the page")
            return page[i:i + total], rowid
        min_local = (u - 12) * 32 // 255 - 23
        k = min_local + (total - min_local) % (u - 4)
        local = k if k <= max_local else min_local
        if i + local + 4 > len(page):
            raise _Bad("cell past the page")
        parts = [page[i:i + local]]
        got = local
        nxt = int.from_bytes(page[i + local:i + local + 4], "big")
        seen: set[int] = set()
        while got < total:
            if not nxt or nxt in seen or nxt > self.count:
                raise _Bad("broken overflow chain")
            seen.add(nxt)
            over = self.page(nxt)
            if over is None:
                raise _Bad("overflow page missing")
            take = min(u - 4, total - got)
            parts.append(over[4:4 + take])
            got += take
            nxt = int.from_bytes(over[0:4], "big")
        return b"".join(parts), rowid

    def leaf_records(self, number: int) -> list[tuple[Any, ...]]:
        page = self.page(number)
        if page is None:
            raise _Bad("page missing")
        base = 100 if number == 1 else 0
        if page[base] != _LEAF_TABLE:
            return []
        cells = int.from_bytes(page[base + 3:base + 5], "big")
        if base + 8 + 2 * cells > len(page):
            raise _Bad("too many cells")
        out = []
        for c in range(cells):
            off = int.from_bytes(page[base + 8 + 2 * c:base + 10 + 2 * c], "big")
            if not base + 8 <= off < len(page):
                raise _Bad("cell offset")
            payload, _ = self.payload(page, off)
            out.append(_record(payload))
        return out


def _is_session(r: tuple[Any, ...]) -> bool:
    return (len(r) in (10, 11) and isinstance(r[0], str) and
            all(isinstance(x, int | float) for x in r[1:5]) and isinstance(r[5], str) and
            all(x is None or isinstance(x, str) for x in r[6:9]) and isinstance(r[9], int))


def salvage(path: str | Path) -> Salvage:
    """Every readable row of the store file ``path`` (and of ``path-wal`` when present).

    Parameters
    ----------
    path : str or Path
        A damaged (or sound) ``sessions.sqlite3``.

    Returns
    -------
    Salvage
        The rows, by table; a file with nothing readable gives empty tables.
    """
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError:
        return Salvage()
    wal_path = Path(f"{path}-wal")
    try:
        wal = wal_path.read_bytes() if wal_path.exists() else None
    except OSError:
        wal = None
    out = Salvage()
    if not data and not wal:
        return out
    f = _File(data, wal)
    for number in range(1, f.count + 1):
        if number in f.free:
            continue
        out.pages += 1
        try:
            records = f.leaf_records(number)
        except (_Bad, IndexError, ValueError):
            out.damaged_pages += 1
            continue
        for r in records:
            if _is_session(r):
                row = tuple(r) + ("",) * (11 - len(r))
                old = out.sessions.get(r[0])
                if old is None or int(row[4]) >= int(old[4]):
                    out.sessions[r[0]] = row
            elif len(r) == 3 and isinstance(r[0], str) and r[1] in _BLOB_KINDS and \
                    isinstance(r[2], bytes):
                out.blobs[(r[0], r[1])] = r[2]
            elif len(r) == 2 and all(isinstance(x, str) for x in r) and r[0] != r[1]:
                out.class_state[r[0]] = r[1]
    return out
