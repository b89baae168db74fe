"""Opening the session store's SQLite file with an integrity check: a damaged file is moved
aside (never repaired in place, never fatal) and a fresh store is started.

At start-up ``PRAGMA quick_check`` reads every page of the file. A file that fails it (a
truncated file, garbage pages, something that is no SQLite database) is renamed next to
itself, ``sessions.sqlite3.damaged-20260102-030405`` (with its ``-wal`` and ``-shm``
companions), kept at mode 0600, and a message on stderr names both paths.
"""

from __future__ import annotations

import os
import sqlite3
import sys
import time
from pathlib import Path

__all__ = ["connect", "move_aside", "problem"]

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


def connect(path: str) -> sqlite3.Connection:
    """The database at ``path`` (``":memory:"`` as is), checked: a damaged file is moved
    aside with a message on stderr and a fresh, empty database opened in its place."""
    db = _open(path)
    if path == ":memory:" or not Path(path).exists():
        return db
    wrong = problem(db)
    if wrong is None:
        return db
    db.close()
    moved = move_aside(Path(path))
    message = (f"the session store {path} is damaged ({wrong}); it was moved aside to "
               f"{moved} and a fresh, empty store was started (sessions from before are "
               "not available; keep the moved file to inspect or recover it)")
    print(message, file=sys.stderr, flush=True)
    return _open(path)
