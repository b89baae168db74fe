"""Explorer sessions shared by the viser GUI and the REST API (no viser / fastapi imports).

A :class:`Session` is one student's sandbox, keyed by a server-made code (79 random bits)
that survives page reloads and restarts: every change is written through to the SQLite
:class:`~app.services.store.SessionStore`. Its :class:`Config` (model, input signal,
mismatch) is an immutable value replaced as a whole; every replacement bumps ``version``
and notifies listeners (the GUI render workers) outside the lock. :mod:`app.compute` turns
a config into the arrays the figures show; :mod:`app.data` and :mod:`app.exports` handle
recordings, fits, diagnoses and downloads.
"""

from __future__ import annotations

import secrets
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from core.exceptions import ParameterError
from core.recordings import Recording
from core.signals import SIGNALS

from .services.store import SessionState, SessionStore

__all__ = [
    "EXAMPLE1",
    "Config",
    "Listener",
    "Session",
    "SessionRegistry",
    "SignalSpec",
    "StoreFullError",
    "config_from_dict",
    "new_code",
    "normalise_code",
]

#: Paper 001 Example 1: r_i = 0.45 i, p0 = 0.72, p = (0.6, 0.48, 0.36, 0.24, 0.12, 0.012).
EXAMPLE1: dict[str, Any] = {
    "type": "pi",
    "p0": 0.72,
    "thresholds": [0.45, 0.9, 1.35, 1.8, 2.25, 2.7],
    "weights": [0.6, 0.48, 0.36, 0.24, 0.12, 0.012],
}

_CODE_ALPHABET = "abcdefghjkmnpqrstuvwxyz23456789"


@dataclass(frozen=True)
class SignalSpec:
    """An input signal ``offset + amplitude * shape(frequency * t)`` on ``[0, duration]``.

    Parameters
    ----------
    kind : str
        Shape name, a key of :data:`core.signals.SIGNALS`.
    amplitude : float
        Peak value, input units.
    frequency : float
        Fundamental frequency, Hz.
    offset : float
        Added constant, input units.
    duration : float
        Length, s.
    samples : int
        Number of samples (uniform spacing ``duration / (samples - 1)``).
    """

    kind: str = "sine"
    amplitude: float = 4.0
    frequency: float = 1.0
    offset: float = 0.0
    duration: float = 2.0
    samples: int = 2000

    def validate(self, max_samples: int) -> None:
        """Raise :class:`ParameterError` naming the first field out of range."""
        if self.kind not in SIGNALS:
            raise ParameterError(
                f"signal.kind {self.kind!r} unknown; known: {', '.join(SIGNALS)}"
            )
        for name in ("amplitude", "frequency", "offset", "duration"):
            if not np.isfinite(getattr(self, name)):
                raise ParameterError(f"signal.{name} must be finite")
        if self.duration <= 0:
            raise ParameterError(f"signal.duration must be > 0 s, got {self.duration:g}")
        if self.frequency < 0:
            raise ParameterError(f"signal.frequency must be >= 0 Hz, got {self.frequency:g}")
        if not 2 <= self.samples <= max_samples:
            raise ParameterError(
                f"signal.samples must be between 2 and {max_samples}, got {self.samples}"
            )


# ----------------------------------------------------------------------------- config
@dataclass(frozen=True, eq=False)
class Config:
    """Everything that determines the plots of one session (replace, never mutate).

    Parameters
    ----------
    model : dict
        The model's ``to_dict()`` form (any registered type).
    signal : SignalSpec
        The input signal.
    mismatch : float
        Relative plant perturbation for the inverse-compensation view, see
        :func:`app.compute.perturb`.
    use_recording : bool
        Drive the model with the uploaded recording's input instead of ``signal``.
    """

    model: dict[str, Any] = field(default_factory=lambda: dict(EXAMPLE1))
    signal: SignalSpec = field(default_factory=SignalSpec)
    mismatch: float = 0.0
    use_recording: bool = False

    def with_model(self, model: dict[str, Any]) -> Config:
        """Copy with another model."""
        return replace(self, model=dict(model))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {
            "model": self.model,
            "signal": self.signal.__dict__.copy(),
            "mismatch": self.mismatch,
            "use_recording": self.use_recording,
        }


# ----------------------------------------------------------------------------- sessions
Listener = Callable[["Session", Config, int], None]


def config_from_dict(d: dict[str, Any]) -> Config:
    """Inverse of :meth:`Config.to_dict` (a stored config)."""
    return Config(model=dict(d["model"]), signal=SignalSpec(**d["signal"]),
                  mismatch=float(d["mismatch"]), use_recording=bool(d["use_recording"]))


@dataclass(eq=False)
class Session:
    """One student's sandbox: config, uploaded data, fit and diagnosis results.

    Every change is written through to the registry's :class:`~app.services.store.
    SessionStore` (committed before the change returns), so a restarted server has it.

    Attributes
    ----------
    code : str
        User-visible session code; type it after a reload to come back.
    config : Config
        Current config snapshot (replaced as a whole by :meth:`set_config`).
    version : int
        Bumped on every config change; render workers skip stale versions.
    teacher : bool
        Created with the teacher token: never evicted.
    """

    code: str
    config: Config = field(default_factory=Config)
    version: int = 0
    recording: Recording | None = None
    fitted: dict[str, Any] | None = None
    fit_report: dict[str, Any] | None = None
    diagnosis: dict[str, Any] | None = None
    diagnosis_result: Any = None
    teacher: bool = False
    created: float = field(default_factory=time.time)
    last_access: float = field(default_factory=time.monotonic)
    lock: threading.RLock = field(default_factory=threading.RLock, repr=False)
    _listeners: list[Listener] = field(default_factory=list, repr=False)
    _store: SessionStore | None = field(default=None, repr=False)

    def snapshot(self) -> tuple[Config, int]:
        """Current ``(config, version)`` read under the lock."""
        with self.lock:
            self.last_access = time.monotonic()
            return self.config, self.version

    def state(self) -> SessionState:
        """The typed, storable state of this session (read under the lock)."""
        with self.lock:
            return SessionState(
                code=self.code, config=self.config.to_dict(), version=self.version,
                recording=self.recording, fitted=self.fitted, fit_report=self.fit_report,
                diagnosis=self.diagnosis, diagnosis_result=self.diagnosis_result,
                teacher=self.teacher, created=self.created,
            )

    @classmethod
    def from_state(cls, st: SessionState) -> Session:
        """A live session from its stored state."""
        return cls(code=st.code, config=config_from_dict(st.config), version=st.version,
                   recording=st.recording, fitted=st.fitted, fit_report=st.fit_report,
                   diagnosis=st.diagnosis, diagnosis_result=st.diagnosis_result,
                   teacher=st.teacher, created=st.created)

    def save(self, *, recording: bool = True, results: bool = True) -> None:
        """Commit the session to its store (no-op without one); see
        :meth:`~app.services.store.SessionStore.save`."""
        if self._store is not None:
            with self.lock:
                self._store.save(self.state(), recording=recording, results=results)

    def set_config(self, config: Config) -> int:
        """Replace the config, bump the version, store, notify listeners; the version."""
        with self.lock:
            self.config = config
            self.version += 1
            self.last_access = time.monotonic()
            v = self.version
            self.save(recording=False, results=False)
        for cb in list(self._listeners):
            cb(self, config, v)
        return v

    def update(self, fn: Callable[[Config], Config]) -> int:
        """Atomically apply ``fn`` to the current config (read-modify-write)."""
        with self.lock:
            return self.set_config(fn(self.config))

    def touch(self) -> None:
        """Store everything and notify listeners (data or fit changed, config did not)."""
        with self.lock:
            self.version += 1
            cfg, v = self.config, self.version
            self.save()
        for cb in list(self._listeners):
            cb(self, cfg, v)

    def add_listener(self, cb: Listener) -> None:
        """Call ``cb(session, config, version)`` after every change."""
        with self.lock:
            self._listeners.append(cb)

    def remove_listener(self, cb: Listener) -> None:
        """Stop notifying ``cb`` (no error if it is not registered)."""
        with self.lock:
            if cb in self._listeners:
                self._listeners.remove(cb)

    def summary(self) -> dict[str, Any]:
        """JSON-ready view of the session."""
        cfg, v = self.snapshot()
        rec = self.recording
        return {
            "code": self.code,
            "version": v,
            "config": cfg.to_dict(),
            "recording": None if rec is None else {"name": rec.name, "samples": rec.n_samples},
            "fitted": self.fitted,
            "has_diagnosis": self.diagnosis is not None,
        }


class StoreFullError(RuntimeError):
    """The session store is over its size budget and nothing may be evicted."""


#: Characters of a session code (no look-alikes: no 0/o, 1/l/i).
CODE_ALPHABET = _CODE_ALPHABET
#: Characters per code: 16 of 31 symbols = 79 random bits.
CODE_LENGTH = 16


def new_code() -> str:
    """A fresh random session code, ``xxxx-xxxx-xxxx-xxxx`` (79 bits from :mod:`secrets`)."""
    raw = "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))
    return "-".join(raw[i:i + 4] for i in range(0, CODE_LENGTH, 4))


def normalise_code(code: str) -> str:
    """The canonical ``xxxx-xxxx-xxxx-xxxx`` form of a typed code; ``KeyError`` if it cannot
    be one (case, spaces and dashes do not matter)."""
    c = "".join(ch for ch in str(code)[:64].lower() if ch not in " -_\t")
    if len(c) != CODE_LENGTH or any(ch not in CODE_ALPHABET for ch in c):
        raise KeyError(code)
    return "-".join(c[i:i + 4] for i in range(0, CODE_LENGTH, 4))


class SessionRegistry:
    """Sessions by code: live ones in memory, all of them in a :class:`SessionStore`.

    Codes are created only here (:func:`new_code`, 79 random bits); an unknown code is a
    ``KeyError``, never a new blank session. Memory holds at most ``max_sessions`` sessions
    (least recently used ones without listeners are dropped from memory, not from the
    store); the store evicts by its size budget (see :mod:`app.services.store`).

    Parameters
    ----------
    max_sessions : int
        Sessions kept in memory.
    store : SessionStore, optional
        Where sessions live; an in-memory SQLite store by default (nothing survives).
    """

    def __init__(self, max_sessions: int = 500, store: SessionStore | None = None) -> None:
        self.max_sessions = max_sessions
        self.store = store if store is not None else SessionStore(":memory:")
        self._lock = threading.Lock()
        self._sessions: OrderedDict[str, Session] = OrderedDict()
        self._used: dict[str, float] = {}

    def create(self, config: Config | None = None, *, teacher: bool = False) -> Session:
        """A new, stored session with a fresh code.

        Raises
        ------
        StoreFullError
            If the store is over its budget with only protected sessions left.
        """
        if self.store.full():
            raise StoreFullError(
                "the server holds as many sessions as its budget allows and all were used "
                "in the last hour; ask the teacher (raise --max-store-mb)")
        with self._lock:
            code = new_code()
            while code in self._sessions or self.store.exists(code):
                code = new_code()
            s = Session(code=code, config=config or Config(), teacher=teacher,
                        _store=self.store)
            s.save()
            self._insert(s)
            self._used[code] = time.time()
            return s

    def _insert(self, s: Session) -> None:
        self._sessions[s.code] = s
        self._sessions.move_to_end(s.code)
        if len(self._sessions) > self.max_sessions:
            for code in list(self._sessions):
                if len(self._sessions) <= self.max_sessions:
                    break
                if not self._sessions[code]._listeners:
                    del self._sessions[code]
                    self._used.pop(code, None)

    def get(self, code: str) -> Session:
        """The session with ``code`` (from memory or the store); ``KeyError`` if none."""
        code = normalise_code(code)
        with self._lock:
            s = self._sessions.get(code)
            if s is None:
                st = self.store.load(code)
                if st is None:
                    raise KeyError(code)
                s = Session.from_state(st)
                s._store = self.store
                self._insert(s)
            else:
                self._sessions.move_to_end(code)
            now = time.time()
            if now - self._used.get(code, 0.0) > 60.0:  # persist uses at most once a minute
                self._used[code] = now
                self.store.touch(code, now)
            return s

    #: The session of a typed code (an unknown code is a ``KeyError``, never a new session).
    join = get
    get_or_create = get

    def all(self) -> list[Session]:
        """Every session in memory."""
        with self._lock:
            return list(self._sessions.values())

    def update_recent(self, fn: Callable[[Config], Config]) -> int:
        """Teacher push: apply ``fn`` to the config of every session used in the last hour
        (stored or in memory; each change committed); returns how many changed."""
        recent = self.store.codes(since=time.time() - self.store.protect_s)
        codes = list(dict.fromkeys([*recent, *(s.code for s in self.all())]))
        n = 0
        for code in codes:
            try:
                s = self.get(code)
            except KeyError:
                continue
            s.update(fn)
            n += 1
        return n

    def push_model(self, model: dict[str, Any]) -> int:
        """Teacher broadcast: give ``model`` to every session used in the last hour."""
        return self.update_recent(lambda c: c.with_model(model))

    def __len__(self) -> int:
        return len(self.store)
