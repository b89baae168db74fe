"""Explorer sessions shared by the viser GUI and the REST API (no viser / fastapi imports).

A :class:`Session` is one student's sandbox, keyed by a short user-visible code that
survives page reloads. Its :class:`Config` (model, input signal, mismatch) is an immutable
value replaced as a whole; every replacement bumps ``version`` and notifies listeners
(the GUI render workers) outside the lock. :mod:`app.compute` turns a config into the
arrays the figures show; :mod:`app.data` and :mod:`app.exports` handle recordings, fits,
diagnoses and downloads.
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

__all__ = [
    "EXAMPLE1",
    "Config",
    "Listener",
    "Session",
    "SessionRegistry",
    "SignalSpec",
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


@dataclass(eq=False)
class Session:
    """One student's sandbox: config, uploaded data, fit and diagnosis results.

    Attributes
    ----------
    code : str
        User-visible session code; type it after a reload to come back.
    config : Config
        Current config snapshot (replaced as a whole by :meth:`set_config`).
    version : int
        Bumped on every config change; render workers skip stale versions.
    """

    code: str
    config: Config = field(default_factory=Config)
    version: int = 0
    recording: Recording | None = None
    fitted: dict[str, Any] | None = None
    fit_report: dict[str, Any] | None = None
    diagnosis: dict[str, Any] | None = None
    diagnosis_result: Any = None
    last_access: float = field(default_factory=time.monotonic)
    lock: threading.RLock = field(default_factory=threading.RLock, repr=False)
    _listeners: list[Listener] = field(default_factory=list, repr=False)

    def snapshot(self) -> tuple[Config, int]:
        """Current ``(config, version)`` read under the lock."""
        with self.lock:
            self.last_access = time.monotonic()
            return self.config, self.version

    def set_config(self, config: Config) -> int:
        """Replace the config, bump the version, notify listeners; returns the version."""
        with self.lock:
            self.config = config
            self.version += 1
            self.last_access = time.monotonic()
            v = self.version
        for cb in list(self._listeners):
            cb(self, config, v)
        return v

    def update(self, fn: Callable[[Config], Config]) -> int:
        """Atomically apply ``fn`` to the current config (read-modify-write)."""
        with self.lock:
            return self.set_config(fn(self.config))

    def touch(self) -> None:
        """Notify listeners without changing the config (data or fit changed)."""
        with self.lock:
            self.version += 1
            cfg, v = self.config, self.version
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


class SessionRegistry:
    """Sessions by code, least-recently-used eviction beyond ``max_sessions``.

    Parameters
    ----------
    max_sessions : int
        How many sessions are kept in memory.
    """

    def __init__(self, max_sessions: int = 500) -> None:
        self.max_sessions = max_sessions
        self._lock = threading.Lock()
        self._sessions: OrderedDict[str, Session] = OrderedDict()

    def new_code(self) -> str:
        """A fresh random 6-character code (no look-alike characters)."""
        while True:
            code = "".join(secrets.choice(_CODE_ALPHABET) for _ in range(6))
            if code not in self._sessions:
                return code

    def create(self, config: Config | None = None) -> Session:
        """A new session with a fresh code."""
        with self._lock:
            s = Session(code=self.new_code(), config=config or Config())
            self._insert(s)
            return s

    def _insert(self, s: Session) -> None:
        self._sessions[s.code] = s
        while len(self._sessions) > self.max_sessions:
            self._sessions.popitem(last=False)

    def get(self, code: str) -> Session:
        """The session with ``code``; raises ``KeyError`` if there is none."""
        code = normalise_code(code)
        with self._lock:
            s = self._sessions[code]
            self._sessions.move_to_end(code)
            return s

    def get_or_create(self, code: str) -> Session:
        """The session with ``code``, created with the default config if new."""
        code = normalise_code(code)
        with self._lock:
            s = self._sessions.get(code)
            if s is None:
                s = Session(code=code)
                self._insert(s)
            self._sessions.move_to_end(code)
            return s

    def all(self) -> list[Session]:
        """Every live session."""
        with self._lock:
            return list(self._sessions.values())

    def push_model(self, model: dict[str, Any]) -> int:
        """Teacher broadcast: give every session ``model``; returns how many changed."""
        sessions = self.all()
        for s in sessions:
            s.update(lambda c: c.with_model(model))
        return len(sessions)

    def __len__(self) -> int:
        return len(self._sessions)


def normalise_code(code: str) -> str:
    """Lower-case, stripped session code; raises ``KeyError`` if malformed."""
    c = str(code).strip().lower()
    if not (3 <= len(c) <= 32) or not all(ch.isalnum() or ch in "-_" for ch in c):
        raise KeyError(code)
    return c
