"""Opening the session store's SQLite file with an integrity check: a damaged file is moved
aside (never repaired in place, never fatal), a fresh store is started, and every session
that can still be read from the damaged file is copied into it.

At start-up ``PRAGMA quick_check`` reads every page of the file. A file that fails it (a
truncated file, garbage pages, something that is no SQLite database) is renamed next to
itself, ``sessions.sqlite3.damaged-20260102-030405`` (with its ``-wal`` and ``-shm``
companions), kept at mode 0600; :func:`restore` then copies the rows of its readable pages
(:func:`app.services.storage.store_salvage.salvage`) into the fresh store, and a message on stderr
names both paths and says how many sessions were saved.
"""

from __future__ import annotations

import os
import sqlite3
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from app.services.storage.store_salvage import salvage

__all__ = ["Damaged", "connect", "move_aside", "problem", "restore"]

#: Companion files of a database in WAL mode.
_COMPANIONS = ("-wal", "-shm")


def _open(path: str) -> sqlite3.Connection:
    return sqlite3.connect(path, check_same_thread=False, isolation_level=None, timeout=30.0)


def problem(db: sqlite3.Connection) -> str | None:
    """What ``PRAGMA quick_check`` finds wrong with ``db`` (``None``: nothing)."""
    try:
        rows = db.execute("PRAGMA quick_check").fetchall()
    except sqlite3.DatabaseError as exc:
        return str(exc)
    found = [str(r[0]) for r in rows]
    return None if found == ["ok"] else "; ".join(found[:3])


def move_aside(path: Path, when: float | None = None) -> Path:
    """Rename ``path`` (and its ``-wal``/``-shm`` files) to ``<name>.damaged-<time>`` next
    to it, mode 0600; returns the new path of the database file."""
    stamp = time.strftime("%Y%m%d-%H%M%S", time.localtime(time.time() if when is None
                                                           else when))
    target = path.with_name(f"{path.name}.damaged-{stamp}")
    n = 1
    while target.exists():
        n += 1
        target = path.with_name(f"{path.name}.damaged-{stamp}-{n}")
    for suffix in ("", *_COMPANIONS):
        src = Path(f"{path}{suffix}")
        if src.exists():
            dst = Path(f"{target}{suffix}")
            src.rename(dst)
            os.chmod(dst, 0o600)
    return target


@dataclass(frozen=True)
class Damaged:
    """A damaged store file, moved aside.

    Attributes
    ----------
    path : str
        Where the store is (its fresh file now).
    moved : Path
        Where the damaged file went.
    problem : str
        What ``PRAGMA quick_check`` found.
    """

    path: str
    moved: Path
    problem: str


def connect(path: str) -> tuple[sqlite3.Connection, Damaged | None]:
    """The database at ``path`` (``":memory:"`` as is), checked: a damaged file is moved
    aside and a fresh, empty database opened in its place (give both to :func:`restore`
    once the schema is there)."""
    db = _open(path)
    if path == ":memory:" or not Path(path).exists():
        return db, None
    wrong = problem(db)
    if wrong is None:
        return db, None
    db.close()
    moved = move_aside(Path(path))
    return _open(path), Damaged(path, moved, wrong)


def restore(db: sqlite3.Connection, damaged: Damaged) -> int:
    """Copy every readable session of the moved file (its rows, its recordings and results,
    the class's lesson) into ``db``, which has the store's schema, and say so on stderr.

    Returns
    -------
    int
        The sessions saved.
    """
    got = salvage(damaged.moved)
    keep = {c: r for c, r in got.sessions.items() if isinstance(c, str) and 0 < len(c) < 64}
    db.execute("BEGIN IMMEDIATE")
    try:
        recordings = 0
        for code, row in keep.items():
            blobs = {k: v for (c, k), v in got.blobs.items() if c == code}
            size = sum(len(t) for t in row[5:9] if isinstance(t, str)) + \
                sum(len(v) for v in blobs.values())
            db.execute("INSERT OR IGNORE INTO sessions (code, created, last_used, teacher, "
                       "version, config, fitted, fit_report, diagnosis, size, owner) "
                       "VALUES (?,?,?,?,?,?,?,?,?,?,?)",
                       (code, float(row[1]), float(row[2]), int(bool(row[3])), int(row[4]),
                        row[5], row[6], row[7], row[8], size,
                        row[10] if isinstance(row[10], str) else ""))
            for kind, data in blobs.items():
                db.execute("INSERT OR IGNORE INTO blobs (code, kind, data) VALUES (?,?,?)",
                           (code, kind, data))
            recordings += "recording" in blobs
        for key, value in got.class_state.items():
            db.execute("INSERT OR IGNORE INTO class_state (key, value) VALUES (?,?)",
                       (key, value))
        db.execute("COMMIT")
    except BaseException:
        db.execute("ROLLBACK")
        raise
    saved = (f"{len(keep)} session(s), {recordings} with a recording, were copied out of its "
             f"readable pages into the fresh store (their codes work as before)"
             if keep else "no session could be read from it")
    print(f"the session store {damaged.path} is damaged ({damaged.problem}); it was moved "
          f"aside to {damaged.moved} and a fresh store was started: {saved}. Keep the moved "
          "file to inspect it or recover more by hand (sqlite3 .recover)",
          file=sys.stderr, flush=True)
    return len(keep)
