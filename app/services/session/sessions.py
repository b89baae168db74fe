"""Live explorer sessions shared by the viser GUI and the REST API (no web imports).

A :class:`Session` is one student's sandbox, keyed by a server-made code (79 random bits)
that survives page reloads and restarts. It holds one typed, frozen
:class:`~app.services.storage.store.SessionState` and replaces it as a whole on every transition
(:meth:`Session.set_config`, :meth:`Session.set_recording`, :meth:`Session.set_fit`,
:meth:`Session.set_diagnosis`): each one bumps the version, is committed to the SQLite
:class:`~app.services.storage.store.SessionStore` before it returns, and notifies the listeners
(the GUI render workers) outside the lock. :class:`SessionRegistry` finds sessions by code.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from app.services.codes import CODE_ALPHABET, CODE_LENGTH, new_code, normalise_code
from app.services.explore.config import Config
from app.services.explore.cost import CheckedModel, Limits
from app.services.storage.store import SessionState, SessionStore, StateChanges
from core.base import Model
from core.recordings import Recording
from core.validation import filled

if TYPE_CHECKING:
    from app.services.analysis.diagnosis import SessionDiagnosis
    from core.diagnosis.results import DiagnosisResult
    from core.fitting.entry import FitOutcome

__all__ = [
    "CODE_ALPHABET",
    "CODE_LENGTH",
    "Listener",
    "Session",
    "SessionRegistry",
    "StoreFullError",
    "new_code",
    "normalise_code",
]

Listener = Callable[["Session", Config, int], None]


class Session:
    """One student's sandbox: a :class:`SessionState` replaced as a whole on each change.

    Parameters
    ----------
    code : str
        User-visible session code; type it after a reload to come back.
    config : Config, optional
        The first config (paper 001 Example 1 by default).
    teacher : bool
        Created with the teacher token: never evicted.
    store : SessionStore, optional
        Where every change is committed (none: nothing is stored).
    owner : str
        The client address that creates it (charged with its share of the store).

    Notes
    -----
    The attributes ``config``, ``version``, ``recording``, ``model``, ``fit``, ``fitted``,
    ``has_diagnosis``, ``diagnosis``, ``diagnosis_note``, ``diagnosed``, ``diagnosis_result``,
    ``teacher`` and ``created`` read the current state (typed: core's ``FitOutcome``,
    ``Model`` and ``DiagnosisResult``; the routers turn them into JSON); change them only
    through the transitions.
    """

    def __init__(self, code: str, config: Config | None = None, *, teacher: bool = False,
                 store: SessionStore | None = None, owner: str = "") -> None:
        self._state = SessionState(code=code, config=config or Config(), teacher=teacher,
                                   owner=owner)
        self._store = store
        self.lock = threading.RLock()
        self.last_access = time.monotonic()
        self._listeners: list[Listener] = []

    @classmethod
    def from_state(cls, state: SessionState, store: SessionStore | None = None) -> Session:
        """A live session from its stored state."""
        s = cls(state.code, store=store)
        s._state = state
        return s

    # ------------------------------------------------------------------ reads
    @property
    def state(self) -> SessionState:
        """The current typed state (a frozen snapshot)."""
        return self._state

    code = property(lambda self: self._state.code, doc="The session code.")
    config = property(lambda self: self._state.config, doc="The current config.")
    version = property(lambda self: self._state.version, doc="Bumped on every change.")
    @property
    def recording(self) -> Recording | None:
        """The uploaded recording: once stored it is read back from the store's cache of
        recently used recordings (or the file), not held by the session."""
        st = self._state
        if st.recording is not None or not st.recording_stored or self._store is None:
            return st.recording
        return self._store.recording(st.code)

    @property
    def fit(self) -> FitOutcome | None:
        """The last fit (core's ``FitOutcome``, without its estimator), or None."""
        return self._state.fit

    @property
    def model(self) -> Model:
        """The current config's model, typed: the one parsed and checked with the config
        when the state holds it (:meth:`checked`), else built from the config's document
        (checked when the config was set or stored)."""
        st = self._state
        if st.checked is not None:
            return st.checked.model
        from core.base import model_from_dict

        return model_from_dict(st.config.model)

    @property
    def fitted(self) -> Model | None:
        """The last fit's model, or None."""
        fit = self._state.fit
        return None if fit is None else fit.model

    @property
    def has_diagnosis(self) -> bool:
        """The session holds a diagnosis (its result)."""
        return self._state.diagnosis_result is not None

    @property
    def diagnosis_note(self) -> str | None:
        """Words for the user when a diagnosis stored by an older version was dropped as
        the session loaded (it could not be rebuilt into a result), else None."""
        return self._state.diagnosis_note

    @property
    def diagnosis(self) -> SessionDiagnosis | None:
        """The diagnosis as the pages show it: the result with its findings in words, in the
        recording's units (:func:`~app.services.analysis.diagnosis.session_diagnosis`); None
        without a diagnosis."""
        result = self._state.diagnosis_result
        if result is None:
            return None
        from app.services.analysis.diagnosis import session_diagnosis

        rec = self.recording
        return session_diagnosis(result, None if rec is None else rec.units)

    @property
    def diagnosed(self) -> Model | None:
        """The diagnosed extended model (the result's, when it added effects), or None."""
        return self._state.diagnosed

    @property
    def diagnosis_result(self) -> DiagnosisResult | None:
        """The core ``DiagnosisResult`` of the diagnosis (stored, rebuilt after a restart),
        or None."""
        return self._state.diagnosis_result

    teacher = property(lambda self: self._state.teacher, doc="A teacher's session.")
    created = property(lambda self: self._state.created, doc="Creation time, s (epoch).")

    def snapshot(self) -> tuple[Config, int]:
        """Current ``(config, version)`` read under the lock."""
        with self.lock:
            self.last_access = time.monotonic()
            return self._state.config, self._state.version

    def checked(self, limits: Limits,
                check: Callable[[Config, Recording | None], CheckedModel]
                ) -> tuple[Config, int, Model]:
        """``(config, version, model)``: the current config's model parsed and checked once.

        The state keeps the :class:`~app.services.explore.cost.CheckedModel` of its config and
        recording; ``check(config, recording)`` builds it only when there is none for
        ``limits`` yet (a new config, a new recording, other limits). Keeping it is no
        transition: the version stays and nothing is stored.

        Raises
        ------
        ParameterError
            From ``check``: the model is invalid or over a limit (nothing is kept).
        """
        with self.lock:
            self.last_access = time.monotonic()
            st = self._state
            if st.checked is None or st.checked.limits != limits:
                st = self._state = replace(st, checked=check(st.config, self.recording))
            return st.config, st.version, filled(st.checked).model

    # ------------------------------------------------------------------ transitions
    def _commit(self, changes: StateChanges, *, recording: bool, results: bool,
                notify: bool = True) -> int:
        """Replace the state with ``changes`` applied and store it; with ``notify`` (a
        change the plots show) also bump the version and tell the listeners. A new config
        or recording drops the checked model unless ``changes`` gives the new one."""
        if ("config" in changes or "recording" in changes) and "checked" not in changes:
            changes = {**changes, "checked": None}
        with self.lock:
            st = replace(self._state, **changes, last_used=time.time(),
                         version=self._state.version + (1 if notify else 0))
            if self._store is not None:
                self._store.save(st, recording=recording, results=results)
                if st.recording is not None:  # on disk now: the store's cache holds it
                    st = replace(st, recording=None, recording_stored=True)
            self._state = st
            self.last_access = time.monotonic()
        if notify:
            for cb in list(self._listeners):
                cb(self, st.config, st.version)
        return st.version

    def save(self) -> None:
        """Commit the whole state to the store (no-op without one)."""
        if self._store is not None:
            with self.lock:
                self._state = replace(self._state, last_used=time.time())
                self._store.save(self._state)

    def set_config(self, config: Config, checked: CheckedModel | None = None) -> int:
        """Replace the config (with ``checked``, its model already parsed and checked);
        returns the new version."""
        return self._commit({"config": config, "checked": checked}, recording=False,
                            results=False)

    def update(self, fn: Callable[[Config], Config]) -> int:
        """Atomically apply ``fn`` to the current config (read-modify-write)."""
        with self.lock:
            return self.set_config(fn(self._state.config))

    def set_recording(self, recording: Recording) -> int:
        """Give the session ``recording``; its fit and diagnosis are dropped."""
        return self._commit({"recording": recording, "recording_stored": False, "fit": None,
                             "diagnosis_result": None, "diagnosis_note": None},
                            recording=True, results=True)

    def set_fit(self, fit: FitOutcome, *, apply: bool = False) -> int:
        """Store a fit (the diagnosis is dropped); ``apply`` makes its model the session's."""
        with self.lock:
            changes: StateChanges = {"fit": fit, "diagnosis_result": None,
                                       "diagnosis_note": None}
            if apply:
                changes["config"] = self._state.config.with_model(fit.model.to_dict())
            return self._commit(changes, recording=False, results=True, notify=apply)

    def set_diagnosis(self, result: DiagnosisResult) -> int:
        """Store a diagnosis, its core result (the plots are not redrawn): the findings are
        made from it, and when it added effects its model is the diagnosed model."""
        return self._commit({"diagnosis_result": result, "diagnosis_note": None},
                            recording=False, results=True, notify=False)

    def touch(self) -> int:
        """Notify listeners and store everything without changing the state (a redraw)."""
        return self._commit({}, recording=True, results=True)

    # ------------------------------------------------------------------ listeners
    def add_listener(self, cb: Listener) -> None:
        """Call ``cb(session, config, version)`` after every change."""
        with self.lock:
            self._listeners.append(cb)

    def remove_listener(self, cb: Listener) -> None:
        """Stop notifying ``cb`` (no error if it is not registered)."""
        with self.lock:
            if cb in self._listeners:
                self._listeners.remove(cb)

    @property
    def listened(self) -> bool:
        """Whether a view listens (such a session is kept in memory)."""
        return bool(self._listeners)

    def use(self) -> SessionState:
        """The current state, read under the lock, the session marked as used (what the
        REST API answers, :func:`app.routers.schemas.session_json`)."""
        with self.lock:
            self.last_access = time.monotonic()
            return self._state


class SessionRegistry:
    """Sessions by code: live ones in memory, all of them in a :class:`SessionStore`.

    Codes are created only here (:func:`new_code`, 79 random bits); an unknown code is a
    ``KeyError``, never a new blank session. Memory holds at most ``max_sessions`` sessions
    (least recently used ones without listeners are dropped from memory, not from the
    store); the store evicts by its size budget (see :mod:`app.services.storage.store`).

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

    def create(self, config: Config | None = None, *, teacher: bool = False,
               owner: str = "") -> Session:
        """A new, stored session with a fresh code.

        Parameters
        ----------
        config : Config, optional
            Its first config.
        teacher : bool
            A teacher's session: never evicted, exempt from the per-client shares, and
            always created: a full store first evicts the heaviest clients' sessions
            (:meth:`SessionStore.make_room`).
        owner : str
            The client address creating it (its share of the store is charged).

        Raises
        ------
        StoreFullError
            If the store is over its budget with only protected sessions left.
        QuotaError
            If ``owner`` already holds its share of sessions.
        """
        if teacher:
            self.store.make_room()
        else:
            if self.store.full():
                raise StoreFullError(
                    f"the server's session store is full ({self.store.size() / 1e6:.0f} MB "
                    f"of its {self.store.max_bytes / 1e6:.0f} MB, every session used in the "
                    "last hour), so no new session can open now: ask the teacher to open a "
                    "teacher session (which makes room) or to restart the server with a "
                    "larger --max-store-mb")
            self.store.admit(owner)
        with self._lock:
            code = new_code()
            while code in self._sessions or self.store.exists(code):
                code = new_code()
            s = Session(code, config, teacher=teacher, store=self.store, owner=owner)
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
                if not self._sessions[code].listened:
                    del self._sessions[code]
                    self._used.pop(code, None)

    def get(self, code: str) -> Session:
        """The session with ``code`` (from memory or the store); ``KeyError`` if none.

        Raises
        ------
        KeyError
            If there is no such session.
        DamagedSessionError
            If its stored state was damaged: it has been reset, the next call returns it.
        """
        code = normalise_code(code)
        with self._lock:
            s = self._sessions.get(code)
            if s is None:
                st = self.store.load(code)
                if st is None:
                    raise KeyError(code)
                s = Session.from_state(st, self.store)
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


class StoreFullError(RuntimeError):
    """The session store is over its size budget and nothing may be evicted."""
