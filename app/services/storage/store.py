"""Durable session state in SQLite (stdlib ``sqlite3``): nothing is lost when the server dies.

Every change of a session (config, recording, fit, diagnosis) is written and committed
before the request that made it returns, so ``kill -9`` and a restart with the same
``--state-dir`` bring every session back under its code. The database is one file,
``sessions.sqlite3``, in WAL mode (a killed writer never corrupts it) with
``synchronous=NORMAL``: a commit is in the write-ahead log, which the operating system keeps
when the process is killed, before the request returns; the log is copied into the database
(a *checkpoint*, the only step that waits for the disk with ``fsync``) by a background
thread every :data:`CHECKPOINT_S` seconds, not by whichever request's commit filled it, so
no request waits for the disk (the slider routes run on the server's event loop).

Eviction is by a stated size budget (``max_bytes``, the sum of the stored rows): when the
store is larger, sessions are deleted **heaviest client first** (the client address that
created them holding the most bytes), its least recently used session first, but **never
one used in the last** ``protect_s`` **seconds (one hour)** and **never a teacher's
session**. If only such sessions remain, the store stays over budget and
:meth:`SessionStore.full` says so (the API then refuses new sessions with 503 rather than
dropping a class); a teacher opening a session then makes room
(:meth:`SessionStore.make_room`: the same order without the one-hour protection).

Each client address also has a share (:class:`~app.services.storage.quotas.Quotas`): the bytes and
the number of stored sessions it created, and the bytes of one session. A save past a
client's share first evicts that client's own sessions unused for ``protect_s``, oldest
first, and raises :class:`~app.services.storage.quotas.QuotaError` (nothing stored) if that is not
enough. Teachers' sessions and sessions of no known client (``owner=""``, created in
process) are exempt from the per-client shares.

The typed state is :class:`SessionState` (a frozen dataclass). Nothing stored is ever
executed: every part is JSON, recordings ``.npz`` arrays (loaded with
``allow_pickle=False``) plus JSON metadata, and a diagnosis its core ``DiagnosisResult``
(:meth:`~core.diagnosis.results.DiagnosisResult.to_json`, compressed; a diagnosis stored
before 2026-12-05, its report and the diagnosed model's document, cannot be rebuilt into a
result and is dropped when its session loads, the state saying so in words,
:mod:`app.services.storage.store_parts`).

The file is checked when the store opens (:mod:`app.services.storage.store_file`: a damaged file is
moved aside, a fresh store started, and every session still readable from the damaged file's
pages copied into it). A session whose stored part does not decode or
validate is reset when it is loaded and :meth:`SessionStore.load` raises
:class:`DamagedSessionError` (the API answers 410 once; the next request works).
"""

from __future__ import annotations

import logging
import os
import sqlite3
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypedDict

from app.services.explore.config import Config
from app.services.explore.cost import CheckedModel
from app.services.storage.quotas import QuotaError, Quotas
from app.services.storage.store_file import connect, restore
from app.services.storage.store_parts import (
    DamagedPartError,
    StoredDiagnosis,
    decode_config,
    decode_diagnosis,
    decode_fit,
    decode_recording,
    dump_json,
    encode_diagnosis,
    encode_fit,
    recording_from_blob,
    recording_to_blob,
)
from core.base import Model
from core.recordings import Recording

if TYPE_CHECKING:
    from core.diagnosis.results import DiagnosisResult
    from core.fitting.entry import FitOutcome

__all__ = ["DamagedSessionError", "SessionState", "SessionStore", "StateChanges",
           "default_state_dir", "recording_from_blob", "recording_to_blob"]

log = logging.getLogger(__name__)

#: Sessions used within this many seconds are never evicted.
PROTECT_S = 3600.0
#: Seconds between two checkpoints of the write-ahead log (background thread).
CHECKPOINT_S = 1.0

_SCHEMA = """
CREATE TABLE IF NOT EXISTS sessions (
    code TEXT PRIMARY KEY,
    created REAL NOT NULL,
    last_used REAL NOT NULL,
    teacher INTEGER NOT NULL DEFAULT 0,
    version INTEGER NOT NULL,
    config TEXT NOT NULL,
    fitted TEXT,
    fit_report TEXT,
    diagnosis TEXT,
    size INTEGER NOT NULL DEFAULT 0,
    owner TEXT NOT NULL DEFAULT ''
);
CREATE TABLE IF NOT EXISTS blobs (
    code TEXT NOT NULL REFERENCES sessions(code) ON DELETE CASCADE,
    kind TEXT NOT NULL,
    data BLOB NOT NULL,
    PRIMARY KEY (code, kind)
);
CREATE INDEX IF NOT EXISTS sessions_last_used ON sessions(last_used);
CREATE TABLE IF NOT EXISTS class_state (
    key TEXT PRIMARY KEY,
    value TEXT NOT NULL
);
"""


def default_state_dir() -> Path:
    """The per-user data directory (``$XDG_DATA_HOME/hysteresis-explorer``, else
    ``~/.local/share/hysteresis-explorer``; ``%LOCALAPPDATA%`` on Windows)."""
    base = os.environ.get("XDG_DATA_HOME") or os.environ.get("LOCALAPPDATA")
    root = Path(base) if base else Path.home() / ".local" / "share"
    return root / "hysteresis-explorer"


@dataclass(frozen=True, eq=False)
class SessionState:
    """Everything one session holds: the one typed session state of the explorer.

    A live :class:`~app.services.session.sessions.Session` holds one of these and replaces it as
    a whole on every transition; the store keeps it.

    Attributes
    ----------
    code : str
        The session code (its only key).
    config : Config
        Model, input signal, mismatch and input source.
    version : int
        Bumped on every change; render workers skip stale versions.
    recording : Recording or None
        Uploaded recording, while it is not yet stored; once stored, a live session's state
        holds ``None`` here and ``recording_stored`` (the arrays stay on disk and in the
        store's small cache, :meth:`SessionStore.recording`).
    recording_stored : bool
        The session has a recording in the store (not held by this state).
    fit : FitOutcome or None
        The last fit (:func:`core.fitting.fit_recordings`' outcome, without its estimator):
        the fitted model, its report and warnings, and the parameter set ``hyst fit`` would
        write. Stored as that parameter set and rebuilt from it.
    diagnosis_result : DiagnosisResult or None
        The core result of the diagnosis (the figure, the HTML report and the findings read
        it): stored as its JSON document (:meth:`DiagnosisResult.to_json`) and rebuilt
        equal after a restart. Its model, when it added effects, is :attr:`diagnosed`.
    diagnosis_note : str or None
        Words for the user when the diagnosis stored with this session in the form of
        before 2026-12-05 was dropped on loading
        (:data:`~app.services.storage.store_parts.OLD_DIAGNOSIS_NOTE`); never stored, and
        cleared by the next fit, recording or diagnosis.
    checked : CheckedModel or None
        The config's model, parsed once and cost-checked for this config and recording
        (``None`` until first needed; dropped whenever the config or the recording
        changes; never stored: it is rebuilt from the config).
    teacher : bool
        A teacher's session (never evicted).
    created, last_used : float
        Wall-clock times, s since the epoch.
    owner : str
        The client address that created the session (its per-client share is charged;
        never shown to anyone); ``""`` when unknown.
    """

    code: str
    config: Config = field(default_factory=Config)
    version: int = 0
    recording: Recording | None = None
    recording_stored: bool = False
    fit: FitOutcome | None = None
    diagnosis_result: DiagnosisResult | None = None
    diagnosis_note: str | None = None
    checked: CheckedModel | None = None
    teacher: bool = False
    created: float = field(default_factory=time.time)
    last_used: float = field(default_factory=time.time)
    owner: str = ""

    @property
    def diagnosed(self) -> Model | None:
        """The diagnosed extended model, the result's model when the diagnosis added effects
        (the Inverse and Closed-loop views use it); ``None`` otherwise."""
        result = self.diagnosis_result
        return result.model if result is not None and result.effects else None


class StateChanges(TypedDict, total=False):
    """Fields of a :class:`SessionState` to replace (``dataclasses.replace(state,
    **changes)``): a transition's changes, or the parts the store decoded. Each key is the
    field of the same name and type (the version, the times and the teacher flag are set
    by the transition or the stored row, never changed through these)."""

    config: Config
    recording: Recording | None
    recording_stored: bool
    fit: FitOutcome | None
    diagnosis_result: DiagnosisResult | None
    diagnosis_note: str | None
    checked: CheckedModel | None


class DamagedSessionError(RuntimeError):
    """A stored session had a damaged part and has been reset (its code still works).

    Attributes
    ----------
    parts : tuple of str
        The damaged parts (``config``, ``recording``, ``fit``, ``diagnosis``).
    """

    def __init__(self, parts: tuple[str, ...]) -> None:
        super().__init__(
            "this session's state was damaged and has been reset (damaged: "
            f"{', '.join(parts)}); the session code still works: upload the recording and "
            "run the fit or the diagnosis again if you need them")
        self.parts = parts


class SessionStore:
    """Sessions in one SQLite file, committed on each change (thread-safe).

    Parameters
    ----------
    path : str or Path
        Database file, or ``":memory:"`` (tests; nothing survives the process).
    max_bytes : int
        Size budget of the stored sessions (rows and blobs), bytes.
    protect_s : float
        Sessions used within this many seconds are never evicted.
    quotas : Quotas, optional
        The shares of one client and one session (:class:`Quotas` defaults).
    recording_cache_bytes : int
        Bytes of recordings kept in memory (the most recently used ones); the others are
        read from the file when needed (:meth:`recording`).
    """

    def __init__(self, path: str | Path, max_bytes: int = 1_000_000_000,
                 protect_s: float = PROTECT_S, quotas: Quotas | None = None,
                 recording_cache_bytes: int = 64_000_000) -> None:
        self.path = str(path)
        self.max_bytes = int(max_bytes)
        self.protect_s = float(protect_s)
        self.quotas = quotas or Quotas()
        self._cache = _RecordingCache(recording_cache_bytes)
        if self.path != ":memory:":
            Path(self.path).parent.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        # a damaged file is moved aside, a fresh one started (its readable sessions copied)
        self._db, damaged = connect(self.path)
        #: Sessions copied out of a damaged file at start-up (``None``: it was sound).
        self.restored: int | None = None
        self._closing = threading.Event()
        self._checkpointer: threading.Thread | None = None
        with self._lock:
            if self.path != ":memory:":
                self._db.execute("PRAGMA journal_mode=WAL")
                self._db.execute("PRAGMA synchronous=NORMAL")  # durable against kill -9
                self._db.execute("PRAGMA wal_autocheckpoint=0")  # the checkpointer's job
                os.chmod(self.path, 0o600)
            self._db.execute("PRAGMA foreign_keys=ON")
            self._db.executescript(_SCHEMA)
            columns = {r[1] for r in self._db.execute("PRAGMA table_info(sessions)")}
            if "owner" not in columns:  # a store written before the per-client shares
                self._db.execute("ALTER TABLE sessions ADD COLUMN owner TEXT NOT NULL "
                                 "DEFAULT ''")
            self._db.execute("CREATE INDEX IF NOT EXISTS sessions_owner ON sessions(owner)")
            if damaged is not None:
                self.restored = restore(self._db, damaged)
        if self.path != ":memory:":
            self._checkpointer = threading.Thread(target=self._checkpoint_loop,
                                                  name="store-checkpoint", daemon=True)
            self._checkpointer.start()

    def _checkpoint_loop(self) -> None:
        """Copy the write-ahead log into the database every :data:`CHECKPOINT_S` s, on a
        connection of its own (a passive checkpoint runs beside the writers)."""
        db = sqlite3.connect(self.path, check_same_thread=False, isolation_level=None,
                             timeout=30.0)
        try:
            while not self._closing.wait(CHECKPOINT_S):
                try:
                    db.execute("PRAGMA wal_checkpoint(PASSIVE)").fetchall()
                except sqlite3.Error as exc:  # retried next time; the log keeps every commit
                    log.warning("the session store's checkpoint failed (%s)", exc)
        finally:
            db.close()

    # ------------------------------------------------------------------ writes
    def save(self, state: SessionState, *, recording: bool = True,
             results: bool = True) -> None:
        """Insert or replace ``state`` and commit.

        ``recording=False`` / ``results=False`` leave the stored recording / diagnosis
        blob as they are (a config change need not rewrite a recording).

        Raises
        ------
        QuotaError
            The session would hold more than its share, or its client (``state.owner``)
            more than its share once its own sessions unused for ``protect_s`` are evicted;
            nothing is stored.
        """
        cfg = dump_json(state.config.to_dict()) or "{}"
        row_text = [cfg, *encode_fit(state.fit), None]  # the diagnosis column: old form only
        blobs: dict[str, bytes | None] = {}
        if recording and (state.recording is not None or not state.recording_stored):
            blobs["recording"] = (None if state.recording is None
                                  else recording_to_blob(state.recording))
        if results:
            blobs["diagnosis"] = encode_diagnosis(state.diagnosis_result)
        with self._lock:
            db = self._db
            if not blobs:  # a config change: one statement, one implicit commit
                cur = db.execute(
                    "UPDATE sessions SET last_used=?, teacher=?, version=?, config=?, fitted=?,"
                    " fit_report=?, diagnosis=?, size=? + (SELECT COALESCE(SUM(length(data)),"
                    " 0) FROM blobs WHERE code=?) WHERE code=?",
                    (state.last_used, int(state.teacher), state.version, *row_text,
                     sum(len(t) for t in row_text if t), state.code, state.code))
                if cur.rowcount == 1:
                    return
            db.execute("BEGIN IMMEDIATE")
            try:
                old = {k: n for k, n in db.execute(
                    "SELECT kind, length(data) FROM blobs WHERE code=?", (state.code,))
                    if k not in blobs}  # the parts given are replaced or deleted
                old.update({k: len(v) for k, v in blobs.items() if v is not None})
                size = sum(len(t) for t in row_text if t) + sum(old.values())
                self._check_share(state, size)
                for kind, data in blobs.items():
                    if data is None:
                        db.execute("DELETE FROM blobs WHERE code=? AND kind=?",
                                   (state.code, kind))
                db.execute(
                    "INSERT INTO sessions (code, created, last_used, teacher, version, config,"
                    " fitted, fit_report, diagnosis, size, owner) VALUES (?,?,?,?,?,?,?,?,?,"
                    "?,?) ON CONFLICT(code) DO UPDATE SET last_used=excluded.last_used, "
                    "teacher=excluded.teacher, version=excluded.version, "
                    "config=excluded.config, fitted=excluded.fitted, "
                    "fit_report=excluded.fit_report, diagnosis=excluded.diagnosis, "
                    "size=excluded.size",
                    (state.code, state.created, state.last_used, int(state.teacher),
                     state.version, *row_text, size, state.owner))
                for kind, data in blobs.items():
                    if data is not None:
                        db.execute("INSERT OR REPLACE INTO blobs (code, kind, data) "
                                   "VALUES (?,?,?)", (state.code, kind, data))
                db.execute("COMMIT")
            except BaseException:
                db.execute("ROLLBACK")
                raise
            if "recording" in blobs:
                self._cache.put(state.code, state.recording)
        if any(v is not None for v in blobs.values()):
            self.evict()  # a recording or a diagnosis may have pushed the store over budget

    def touch(self, code: str, when: float | None = None) -> None:
        """Record a use of ``code`` (for the one-hour eviction protection)."""
        with self._lock:
            self._db.execute("UPDATE sessions SET last_used=? WHERE code=?",
                             (time.time() if when is None else when, code))

    def delete(self, code: str) -> None:
        """Remove ``code`` and its blobs."""
        with self._lock:
            self._db.execute("DELETE FROM sessions WHERE code=?", (code,))
            self._cache.put(code, None)

    def recording(self, code: str) -> Recording | None:
        """The stored recording of ``code`` (from the cache of recently used ones, else read
        from the file and cached), or ``None``.

        Raises
        ------
        DamagedSessionError
            Its stored recording no longer decodes: the session has been reset.
        """
        rec = self._cache.get(code)
        if rec is not None:
            return rec
        with self._lock:
            row = self._db.execute("SELECT data FROM blobs WHERE code=? AND kind='recording'",
                                   (code,)).fetchone()
        if row is None:
            return None
        try:
            rec = decode_recording(row[0])
        except DamagedPartError as exc:
            meta = self._db.execute("SELECT created, teacher, version, owner FROM sessions "
                                    "WHERE code=?", (code,)).fetchone()
            if meta is None:
                return None
            self._reset(code, created=meta[0], teacher=bool(meta[1]), version=meta[2],
                        owner=meta[3], damaged=[exc])
        self._cache.put(code, rec)
        return rec

    def put_class_state(self, key: str, value: str | None) -> None:
        """Store (or, with ``None``, delete) a piece of the class's state that is no
        session's: the lesson the class follows (:mod:`~app.services.teaching.lessons`).
        Committed."""
        with self._lock:
            if value is None:
                self._db.execute("DELETE FROM class_state WHERE key=?", (key,))
            else:
                self._db.execute("INSERT OR REPLACE INTO class_state (key, value) "
                                 "VALUES (?,?)", (key, value))

    def class_state(self, key: str) -> str | None:
        """The stored class state ``key`` (:meth:`put_class_state`), or ``None``."""
        with self._lock:
            row = self._db.execute("SELECT value FROM class_state WHERE key=?",
                                   (key,)).fetchone()
        return None if row is None else str(row[0])

    # ------------------------------------------------------------------ reads
    def load(self, code: str) -> SessionState | None:
        """The stored session ``code``, or ``None``.

        Raises
        ------
        DamagedSessionError
            If a part did not decode or validate: the session has been reset to a fresh
            state under the same code (kept: its teacher flag and creation time), so the
            next load works. Logged without the code.
        """
        with self._lock:
            row = self._db.execute(
                "SELECT code, created, last_used, teacher, version, config, fitted, "
                "fit_report, diagnosis, owner FROM sessions WHERE code=?", (code,)).fetchone()
            blobs = dict(self._db.execute("SELECT kind, data FROM blobs WHERE code=?",
                                          (code,)).fetchall()) if row else {}
        if row is None:
            return None
        parts: StateChanges = {}
        damaged: list[DamagedPartError] = []
        def recording() -> StateChanges:  # checked now, then kept on disk (and cached)
            rec = decode_recording(blobs.get("recording"))
            if rec is not None:
                self._cache.put(code, rec)
            return {"recording_stored": rec is not None}

        def diagnosis(stored: StoredDiagnosis) -> StateChanges:
            if stored.note is not None:
                log.info("a session's diagnosis stored in the form of before 2026-12-05 was "
                         "dropped (it cannot be rebuilt into a result)")
            return {"diagnosis_result": stored.result, "diagnosis_note": stored.note}

        decoders: tuple[Callable[[], StateChanges], ...] = (
            lambda: {"config": decode_config(row[5])},
            recording,
            lambda: {"fit": decode_fit(row[6], row[7])},
            lambda: diagnosis(decode_diagnosis(row[8], blobs.get("diagnosis"))),
        )
        for decode in decoders:
            try:
                parts.update(decode())
            except DamagedPartError as exc:
                damaged.append(exc)
        if damaged:
            self._reset(code, created=row[1], teacher=bool(row[3]), version=row[4],
                        owner=row[9], damaged=damaged)
        return SessionState(code=row[0], created=row[1], last_used=row[2],
                            teacher=bool(row[3]), version=row[4], owner=row[9], **parts)

    def _reset(self, code: str, *, created: float, teacher: bool, version: int,
               owner: str, damaged: list[DamagedPartError]) -> None:
        """Replace the damaged session ``code`` by a fresh state and raise."""
        names = tuple(e.part for e in damaged)
        log.warning("a stored session was damaged and has been reset (%s)",
                    "; ".join(f"{e.part}: {e.reason}" for e in damaged))
        self.delete(code)
        self.save(SessionState(code=code, created=created, teacher=teacher,
                               version=version + 1, owner=owner))
        raise DamagedSessionError(names)

    def exists(self, code: str) -> bool:
        """Whether ``code`` is stored."""
        with self._lock:
            return self._db.execute("SELECT 1 FROM sessions WHERE code=?",
                                    (code,)).fetchone() is not None

    def codes(self, since: float = 0.0) -> list[str]:
        """Stored codes used at or after ``since`` (s since the epoch), most recent first."""
        with self._lock:
            return [r[0] for r in self._db.execute(
                "SELECT code FROM sessions WHERE last_used>=? ORDER BY last_used DESC",
                (since,))]

    def size(self) -> int:
        """Bytes held (rows and blobs), the quantity the budget bounds."""
        with self._lock:
            return int(self._db.execute("SELECT COALESCE(SUM(size), 0) FROM sessions"
                                        ).fetchone()[0])

    def __len__(self) -> int:
        with self._lock:
            return int(self._db.execute("SELECT COUNT(*) FROM sessions").fetchone()[0])

    # ------------------------------------------------------------------ budget
    def _check_share(self, state: SessionState, size: int) -> None:
        """Raise :class:`QuotaError` if ``state`` stored at ``size`` bytes passes its own
        share or its client's (after evicting that client's own sessions unused for
        ``protect_s``, oldest first). Runs under the lock, inside the save's transaction."""
        q = self.quotas
        if size > q.session_bytes:
            raise QuotaError.session_bytes(size, q.session_bytes)
        if state.teacher or not state.owner:
            return
        db = self._db
        held = int(db.execute("SELECT COALESCE(SUM(size), 0) FROM sessions WHERE owner=? "
                              "AND code<>? AND teacher=0", (state.owner, state.code)
                              ).fetchone()[0])
        if held + size <= q.client_bytes:
            return
        idle = db.execute("SELECT code, size FROM sessions WHERE owner=? AND code<>? AND "
                          "teacher=0 AND last_used<? ORDER BY last_used",
                          (state.owner, state.code, time.time() - self.protect_s)).fetchall()
        for code, n in idle:
            if held + size <= q.client_bytes:
                break
            db.execute("DELETE FROM sessions WHERE code=?", (code,))
            held -= int(n)
        if held + size > q.client_bytes:
            raise QuotaError.client_bytes(held, size, q.client_bytes)

    def admit(self, owner: str) -> None:
        """Check that client ``owner`` may have one more stored session: beyond its share
        of sessions, its own sessions unused for ``protect_s`` are evicted, oldest first.

        Raises
        ------
        QuotaError
            ``owner`` still holds its share of sessions (nothing was evicted).
        """
        if not owner:
            return
        quota = self.quotas.client_sessions
        with self._lock:
            db = self._db
            held = int(db.execute("SELECT COUNT(*) FROM sessions WHERE owner=? AND "
                                  "teacher=0", (owner,)).fetchone()[0])
            if held < quota:
                return
            idle = [r[0] for r in db.execute(
                "SELECT code FROM sessions WHERE owner=? AND teacher=0 AND last_used<? "
                "ORDER BY last_used LIMIT ?",
                (owner, time.time() - self.protect_s, held - quota + 1))]
            if held - len(idle) >= quota:
                raise QuotaError.client_sessions(held, quota)
            db.executemany("DELETE FROM sessions WHERE code=?", [(c,) for c in idle])

    def held(self, owner: str) -> tuple[int, int]:
        """``(sessions, bytes)`` stored of the sessions client ``owner`` created (but
        teachers' sessions: the share it is charged)."""
        with self._lock:
            n, size = self._db.execute("SELECT COUNT(*), COALESCE(SUM(size), 0) FROM "
                                       "sessions WHERE owner=? AND teacher=0",
                                       (owner,)).fetchone()
        return int(n), int(size)

    def evict(self, now: float | None = None, *, protect: bool = True,
              target: int | None = None) -> list[str]:
        """Delete sessions until the store fits ``max_bytes`` (or ``target`` bytes):
        the heaviest client's least recently used session first.

        The heaviest client is the creator address whose stored sessions hold the most
        bytes (sessions of no known client count as one client); after each deletion the
        order is taken again. Never a teacher's session, and with ``protect`` never one
        used within ``protect_s`` seconds.

        Returns
        -------
        list of str
            The evicted codes, in the order they went.
        """
        now = time.time() if now is None else now
        goal = self.max_bytes if target is None else int(target)
        out: list[str] = []
        with self._lock:
            db = self._db
            total = int(db.execute("SELECT COALESCE(SUM(size), 0) FROM sessions"
                                   ).fetchone()[0])
            if total <= goal:
                return out
            weight = dict(db.execute("SELECT owner, SUM(size) FROM sessions GROUP BY owner"))
            queues: dict[str, list[tuple[str, int]]] = {}
            for code, owner, size in db.execute(
                    "SELECT code, owner, size FROM sessions WHERE teacher=0 AND last_used<? "
                    "ORDER BY last_used DESC",
                    (now - self.protect_s if protect else float("inf"),)):
                queues.setdefault(owner, []).append((code, int(size)))  # oldest last
            while total > goal and queues:
                owner = max(queues, key=lambda o: (weight.get(o, 0), o))
                code, size = queues[owner].pop()
                if not queues[owner]:
                    del queues[owner]
                db.execute("DELETE FROM sessions WHERE code=?", (code,))
                weight[owner] = weight.get(owner, 0) - size
                total -= size
                out.append(code)
        return out

    def full(self) -> bool:
        """Over budget even after :meth:`evict` (only protected sessions are left)."""
        self.evict()
        return self.size() > self.max_bytes

    def make_room(self, share: float = 0.9) -> list[str]:
        """A teacher's eviction: when the store is over budget, evict in the same order
        as :meth:`evict` but also sessions used within the hour (never a teacher's), until
        the store holds at most ``share`` of its budget. Logged (without codes).

        Returns
        -------
        list of str
            The evicted codes.
        """
        if self.size() <= self.max_bytes:
            return []
        out = self.evict(protect=False, target=int(share * self.max_bytes))
        log.warning("the session store was full: opening a teacher's session evicted %d "
                    "session(s), those of the computers holding the most first", len(out))
        return out

    def close(self) -> None:
        """Close the database (every change is already committed; closing the last
        connection checkpoints the log)."""
        self._closing.set()
        if self._checkpointer is not None:
            self._checkpointer.join(timeout=30)
        with self._lock:
            self._db.close()


class _RecordingCache:
    """The most recently used recordings, up to ``max_bytes`` of arrays (thread-safe)."""

    def __init__(self, max_bytes: int) -> None:
        self.max_bytes = int(max_bytes)
        self._lock = threading.Lock()
        self._items: OrderedDict[str, tuple[Recording, int]] = OrderedDict()
        self._bytes = 0

    @staticmethod
    def _size(rec: Recording) -> int:
        arrays = [rec.t, rec.u, rec.y, getattr(rec, "lines", None),
                  *(getattr(rec, "extra", None) or {}).values()]
        return sum(int(getattr(a, "nbytes", 0)) for a in arrays if a is not None)

    def get(self, code: str) -> Recording | None:
        with self._lock:
            item = self._items.get(code)
            if item is None:
                return None
            self._items.move_to_end(code)
            return item[0]

    def put(self, code: str, rec: Recording | None) -> None:
        with self._lock:
            old = self._items.pop(code, None)
            if old is not None:
                self._bytes -= old[1]
            if rec is None:
                return
            n = self._size(rec)
            self._items[code] = (rec, n)
            self._bytes += n
            while self._bytes > self.max_bytes and len(self._items) > 1:
                _, (_, m) = self._items.popitem(last=False)
                self._bytes -= m


def with_use(state: SessionState, when: float | None = None) -> SessionState:
    """``state`` marked as used at ``when`` (now by default)."""
    return replace(state, last_used=time.time() if when is None else when)
