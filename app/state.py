"""Explorer state shared by the viser GUI and the REST API (no viser / fastapi imports).

A :class:`Session` is one student's sandbox, keyed by a short user-visible code that
survives page reloads. Its :class:`Config` (model, input signal, mismatch) is an immutable
value replaced as a whole; every replacement bumps ``version`` and notifies listeners
(the GUI render workers) outside the lock. :func:`compute` turns a config into a
:class:`Result` with everything the figures need.

Capabilities that live in modules other developers write (signals, presets, digitized
PI, closed loop, CSV reading, fitting, diagnosis, exports) are imported lazily through
:func:`optional`, so the explorer works with the classical PI model alone and each
capability lights up as soon as its module exists.
"""

from __future__ import annotations

import importlib
import secrets
import threading
import time
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from types import ModuleType
from typing import Any

import numpy as np

from core.base import Chain, Model, model_from_dict
from core.exceptions import NotInvertibleError, ParameterError
from core.pi import PIModel

__all__ = [
    "EXAMPLE1",
    "Config",
    "Recording",
    "Result",
    "Session",
    "SessionRegistry",
    "SignalSpec",
    "compute",
    "make_signal",
    "optional",
    "perturb",
    "signal_kinds",
]

#: Paper 001 Example 1: r_i = 0.45 i, p0 = 0.72, p = (0.6, 0.48, 0.36, 0.24, 0.12, 0.012).
EXAMPLE1: dict[str, Any] = {
    "type": "pi",
    "p0": 0.72,
    "thresholds": [0.45, 0.9, 1.35, 1.8, 2.25, 2.7],
    "weights": [0.6, 0.48, 0.36, 0.24, 0.12, 0.012],
}

_CODE_ALPHABET = "abcdefghjkmnpqrstuvwxyz23456789"


def ensure_model_types() -> list[str]:
    """Import every core model module so all model types are registered."""
    mod = optional("core.paramset")
    if mod is not None and hasattr(mod, "ensure_model_types_registered"):
        return list(mod.ensure_model_types_registered())
    for name in ("core.deadzone", "core.gpi", "core.digitized"):
        optional(name)
    from core.base import registered_types

    return registered_types()


def optional(name: str) -> ModuleType | None:
    """Import ``name`` if it exists, else ``None`` (a capability not landed yet)."""
    try:
        return importlib.import_module(name)
    except ImportError:
        return None


# ----------------------------------------------------------------------------- signals
def _fallback_signal(kind: str, t: np.ndarray, a: float, f: float) -> np.ndarray:
    ph = 2 * np.pi * f * t
    if kind == "sine":
        return a * np.sin(ph)
    if kind == "triangle":
        return a * (2 / np.pi) * np.arcsin(np.sin(ph))
    if kind == "decaying-sine":
        dur = max(float(t[-1]), 1e-12)
        return a * np.exp(-2.5 * t / dur) * np.sin(ph)
    raise ParameterError(f"signal kind {kind!r} unknown; known: {', '.join(signal_kinds())}")


def _core_signals() -> dict[str, Any]:
    mod = optional("core.signals")
    reg = getattr(mod, "SIGNALS", None) if mod is not None else None
    return dict(reg) if reg is not None else {}


def signal_kinds() -> list[str]:
    """Names of the available input signals (the core's registry, else built-ins)."""
    names = list(_core_signals())
    return names or ["sine", "triangle", "decaying-sine"]


@dataclass(frozen=True)
class SignalSpec:
    """An input signal ``offset + amplitude * shape(frequency * t)`` on ``[0, duration]``.

    Parameters
    ----------
    kind : str
        Shape name, one of :func:`signal_kinds`.
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
        if self.kind not in signal_kinds():
            raise ParameterError(
                f"signal.kind {self.kind!r} unknown; known: {', '.join(signal_kinds())}"
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


def make_signal(spec: SignalSpec) -> tuple[np.ndarray, np.ndarray]:
    """Sample times ``t`` (s) and input ``u`` of ``spec``.

    With :mod:`core.signals` the registered generator is called with the parameters it
    accepts (``amplitude``, ``frequency``/``f0``, ``offset``, ``duration`` and the sample
    rate ``(samples - 1) / duration``); signals without a duration (staircase) choose
    their own length. Otherwise a built-in sine/triangle/decaying sine is sampled.
    """
    reg = _core_signals()
    if spec.kind in reg:
        gen = reg[spec.kind]
        names = {p.name for p in getattr(gen, "params", ())}
        kw: dict[str, Any] = {"sample_rate": (spec.samples - 1) / spec.duration}
        for key in ("amplitude", "frequency", "offset", "duration"):
            if key in names:
                kw[key] = getattr(spec, key)
        if "frequency" not in names and "f0" in names:
            kw["f0"] = spec.frequency
        kw = {k: v for k, v in kw.items() if k in names}
        t, u = gen.build(**kw)
        return np.asarray(t, dtype=np.float64), np.asarray(u, dtype=np.float64)
    t = np.linspace(0.0, spec.duration, spec.samples)
    u = _fallback_signal(spec.kind, t, spec.amplitude, spec.frequency)
    return t, np.asarray(u, dtype=np.float64) + spec.offset


# ----------------------------------------------------------------------------- data
@dataclass(frozen=True, eq=False)
class Recording:
    """A measured (or uploaded) record: time ``t`` (s), input ``u``, output ``y``."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    name: str = "recording"

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.u.size)


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
        Relative plant perturbation for the inverse-compensation view, see :func:`perturb`.
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


def build_model(d: dict[str, Any], max_operators: int) -> Model:
    """Validated model from its dict form, enforcing the operator limit."""
    m = model_from_dict(d)
    n = getattr(m, "n", None)
    if isinstance(n, int) and n > max_operators:
        raise ParameterError(
            f"model has {n} operators; the explorer allows at most {max_operators}"
        )
    return m


def pi_part(model: Model) -> PIModel | None:
    """The classical PI model inside ``model`` (itself, or a chain stage), else ``None``."""
    if isinstance(model, PIModel):
        return model
    stages = getattr(model, "stages", ())
    for st in stages:
        if isinstance(st, PIModel):
            return st
    return None


def perturb(model: Model, mismatch: float) -> Model:
    """The "real plant" used against an inverse built from ``model``.

    Thresholds are scaled by ``1 + mismatch`` and the play weights by ``1 - mismatch``
    (``p0`` is kept), so ``mismatch = 0`` returns ``model`` and ``±0.2`` gives a plant whose
    loop is visibly wider or narrower than the model's. Non-PI models are returned as is.
    """
    if mismatch == 0:
        return model
    if isinstance(model, Chain):
        return Chain(tuple(perturb(st, mismatch) for st in model.stages))
    if not isinstance(model, PIModel):
        return model
    return PIModel(
        model.p0, model.thresholds * (1 + mismatch), model.weights * (1 - mismatch), model.state0
    )


#: Largest number of digits the digitized view builds a state graph for (2**n states).
MAX_GRAPH_DIGITS = 10


@dataclass(frozen=True, eq=False)
class Digitized:
    """Digitized (binary-state) view of the run (paper 000).

    Attributes
    ----------
    model : DigitizedPI
        The digitized model (``H = [dx; dy]``, origin ``(x0, y0)``).
    trace : DigitizedTrace
        States visited by the input (digit rows, sample index of each state).
    graph : StateGraph or None
        All ``2**n`` states and their edges (``None`` beyond :data:`MAX_GRAPH_DIGITS`).
    y : ndarray of shape (N,)
        Digitized output.
    y_classical : ndarray of shape (N,)
        The equivalent classical PI (:meth:`DigitizedPI.to_pi`) on the same input.
    """

    model: Any
    trace: Any
    graph: Any
    y: np.ndarray
    y_classical: np.ndarray

    @property
    def H(self) -> np.ndarray:  # noqa: N802 - the paper's name
        """Paired properties ``[Δx; Δy]``, shape ``(2, n)``."""
        return np.vstack((self.model.dx, self.model.dy))

    def state_at(self, k: int) -> int:
        """Index of the trace row active at sample ``k``."""
        return int(np.searchsorted(self.trace.sample, k, side="right") - 1)


def digitize(model: Model, u: np.ndarray) -> tuple[Digitized | None, str | None]:
    """The digitized view of ``model`` driven by ``u``, or ``(None, reason)``."""
    mod = optional("core.digitized")
    if mod is None:
        return None, "the digitized PI module is not installed"
    dig = None
    if type(model).__name__ == "DigitizedPI":
        dig = model
    else:
        pi = pi_part(model)
        if pi is None:
            return None, "the digitized view needs a classical PI (or digitized) model"
        lo, hi = float(np.min(u)), float(np.max(u))
        if 0.5 * (hi - lo) <= pi.thresholds[-1]:
            return None, (
                f"the input's half span {0.5 * (hi - lo):.3g} must exceed the largest "
                f"threshold {pi.thresholds[-1]:.3g}: raise the amplitude"
            )
        dig = mod.DigitizedPI.from_pi(pi, (lo, hi))
    tr = dig.trace(u)
    graph = dig.state_graph() if dig.n <= MAX_GRAPH_DIGITS else None
    y_cl = dig.to_pi().simulate(u).y + float(dig.classical_offset)
    return Digitized(dig, tr, graph, np.asarray(tr.y), y_cl), None


@dataclass(frozen=True, eq=False)
class Result:
    """Everything the figures show for one config (arrays of shape ``(N,)`` unless noted)."""

    version: int
    model: Model
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    contributions: np.ndarray | None = None  # (M, n): p_i * Γ_{r_i}[u] at contrib_idx
    contrib_idx: np.ndarray | None = None  # (M,) sample indices of the contribution rows
    v: np.ndarray | None = None  # inverse's output (plant input) for desired output u
    y_comp: np.ndarray | None = None  # plant(v): compensated output
    inverse_error: str | None = None
    y_measured: np.ndarray | None = None
    digitized: Digitized | None = None
    messages: tuple[str, ...] = ()
    elapsed_ms: float = 0.0


def decimate_index(u: np.ndarray, max_points: int = 1500) -> np.ndarray:
    """Indices of at most about ``max_points`` samples, always keeping input reversals.

    Parameters
    ----------
    u : ndarray of shape (N,)
        The input whose turning points must survive (loop corners).
    max_points : int
        Target number of points.

    Returns
    -------
    ndarray of int
        Sorted unique indices including ``0`` and ``N - 1``.
    """
    n = int(u.size)
    if n <= max_points:
        return np.arange(n)
    stride = int(np.ceil(n / max_points))
    base = np.arange(0, n, stride)
    d = np.sign(np.diff(u))
    turns = np.flatnonzero(d[1:] * d[:-1] < 0) + 1
    if turns.size > max_points // 2:
        turns = turns[:: int(np.ceil(2 * turns.size / max_points))]
    return np.unique(np.concatenate((base, turns, [n - 1])))


#: Rows of the operator-contribution matrix kept for the stacked plot.
CONTRIB_ROWS = 400
#: Samples per chunk when the play-operator matrix is computed piecewise.
CONTRIB_CHUNK = 20_000


def operator_contributions(pi: PIModel, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``p_i Γ_{r_i}[u]`` at about :data:`CONTRIB_ROWS` samples (reversals kept).

    The play states are carried from chunk to chunk, so memory stays at
    ``CONTRIB_CHUNK × n`` floats whatever the signal length.

    Returns
    -------
    idx : ndarray of int, shape (M,)
        Sample indices.
    contrib : ndarray of shape (M, n)
    """
    from core.operators import play_bank

    idx = decimate_index(u, CONTRIB_ROWS)
    out = np.empty((idx.size, pi.n))
    z = np.array(pi.state0, dtype=np.float64)
    for start in range(0, u.size, CONTRIB_CHUNK):
        stop = min(u.size, start + CONTRIB_CHUNK)
        Y, z = play_bank(u[start:stop], pi.thresholds, z)
        sel = (idx >= start) & (idx < stop)
        out[sel] = Y[idx[sel] - start]
    return idx, out * pi.weights


class _Skip(Exception):
    """Internal: a part of :func:`compute` that was not asked for."""


def validate_config(config: Config, recording: Recording | None, max_operators: int,
                    max_samples: int) -> None:
    """Check ``config`` without simulating; raises :class:`ParameterError`."""
    build_model(config.model, max_operators)
    if not (config.use_recording and recording is not None):
        config.signal.validate(max_samples)


def compute(
    config: Config,
    *,
    version: int = 0,
    recording: Recording | None = None,
    max_operators: int = 100,
    max_samples: int = 200_000,
    with_inverse: bool = True,
    with_digitized: bool = True,
) -> Result:
    """Simulate ``config``: output, operator contributions and inverse compensation.

    ``with_inverse`` / ``with_digitized`` skip the inverse-compensation run and the
    digitized view when the figure on show does not need them.

    Raises
    ------
    ParameterError
        If the model or the signal is invalid (the message names the field).
    """
    t0 = time.perf_counter()
    model = build_model(config.model, max_operators)
    y_meas = None
    if config.use_recording and recording is not None:
        t, u, y_meas = recording.t, recording.u, recording.y
    else:
        config.signal.validate(max_samples)
        t, u = make_signal(config.signal)
    dt = float(t[1] - t[0]) if t.size > 1 else None
    if u.size > max_samples:
        raise ParameterError(f"the input has {u.size} samples; at most {max_samples} allowed")
    y = model.simulate(u, dt=dt).y
    contrib = contrib_idx = None
    pi = pi_part(model)
    if pi is not None:
        contrib_idx, contrib = operator_contributions(pi, u)
    v = y_comp = None
    inv_err = None
    try:
        if not with_inverse:
            raise _Skip
        inv = model.inverse()
        # desired output = the signal; plant input v = P^-1(u); plant output P~(v)
        v = inv.simulate(u, dt=dt).y
        y_comp = perturb(model, config.mismatch).simulate(v, dt=dt).y
    except _Skip:
        pass
    except NotInvertibleError as exc:
        inv_err = str(exc)
    except ValueError as exc:  # e.g. an input outside an inverse's domain
        inv_err = f"inverse unavailable: {exc}"
    digi, digi_msg = None, None
    try:
        if with_digitized:
            digi, digi_msg = digitize(model, u)
    except (ParameterError, ValueError) as exc:
        digi_msg = f"digitized view unavailable: {exc}"
    return Result(
        version=version,
        model=model,
        digitized=digi,
        messages=(digi_msg,) if digi_msg else (),
        t=t,
        u=u,
        y=y,
        contributions=contrib,
        contrib_idx=contrib_idx,
        v=v,
        y_comp=y_comp,
        inverse_error=inv_err,
        y_measured=y_meas,
        elapsed_ms=1e3 * (time.perf_counter() - t0),
    )


# ----------------------------------------------------------------------------- closed loop
#: Sample rate of the closed-loop runs (paper 001's plant has poles near 3-4 kHz).
CLOSED_LOOP_RATE = 50_000.0
#: Longest closed-loop run, s (100,000 samples at 50 kHz).
CLOSED_LOOP_MAX_S = 2.0


@dataclass(frozen=True, eq=False)
class ClosedLoop:
    """Paper 001 Fig. 15-16: PI controller + ``G(s)`` (eq. 38) around the hysteresis.

    Attributes
    ----------
    runs : dict
        ``{"no compensation": ClosedLoopResult, "inverse feedforward": ...,
        "inverse + reference feedforward": ...}``; the plant's hysteresis is the
        (mismatch-perturbed) session model, the feedforward is the exact inverse of the
        unperturbed model; the last run adds the reference to the controller output
        (two-degree-of-freedom structure, not in the paper's Fig. 15).
    """

    runs: dict[str, Any]


def closed_loop(res: Result, mismatch: float) -> tuple[ClosedLoop | None, str | None]:
    """Closed-loop runs of ``res``'s model tracking ``res.u`` as the reference."""
    mod = optional("core.closed_loop")
    if mod is None:
        return None, "the closed-loop module is not installed"
    pi = res.model if isinstance(res.model, PIModel) else None
    if pi is None:
        return None, "the closed loop is simulated for classical PI models only"
    dur = min(float(res.t[-1] - res.t[0]), CLOSED_LOOP_MAX_S)
    tt = np.arange(0.0, dur, 1.0 / CLOSED_LOOP_RATE)
    r = np.interp(tt + res.t[0], res.t, res.u)
    plant_h = perturb(pi, mismatch)
    runs: dict[str, Any] = {}
    g = mod.paper001_plant()
    runs["no compensation"] = mod.HammersteinLoop(plant_h, g).simulate(r, 1.0 / CLOSED_LOOP_RATE)
    try:
        ff = pi.inverse()
    except NotInvertibleError as exc:
        return ClosedLoop(runs), f"no inverse feedforward: {exc}"
    runs["inverse feedforward"] = mod.HammersteinLoop(plant_h, g, feedforward=ff).simulate(
        r, 1.0 / CLOSED_LOOP_RATE)
    runs["inverse + reference feedforward"] = mod.HammersteinLoop(
        plant_h, g, feedforward=ff, reference_feedforward=True).simulate(r, 1.0 / CLOSED_LOOP_RATE)
    return ClosedLoop(runs), None


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
            "recording": None if rec is None else {"name": rec.name, "samples": rec.n},
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


# ----------------------------------------------------------------------------- data services
class CSVProblem(ValueError):
    """A CSV upload could not be read.

    ``line`` is the 1-based line of the file, ``column`` the 0-based column index (as in the
    messages of :mod:`core.csvio`: ``'y' (column 2)`` is the third column).
    """

    def __init__(self, message: str, line: int | None = None, column: int | None = None):
        super().__init__(message)
        self.line = line
        self.column = column


def _split(line: str, delim: str | None) -> list[str]:
    return [c.strip() for c in (line.split(delim) if delim else line.split())]


def _sniff(lines: list[str]) -> str | None:
    sample = "\n".join(lines[:5])
    for d in (",", ";", "\t"):
        if d in sample:
            return d
    return None


def parse_table(text: str, max_samples: int) -> tuple[list[str], np.ndarray]:
    """Parse a numeric CSV table (``,``/``;``/tab/space separated, optional header row).

    Returns
    -------
    header : list of str
        Column names (``col1``, ``col2``, ... when the file has no header).
    table : ndarray of shape (rows, columns)

    Raises
    ------
    CSVProblem
        With the 1-based line and column of the first bad cell.
    """
    raw = [ln for ln in text.splitlines()]
    numbered = [(i + 1, ln) for i, ln in enumerate(raw) if ln.strip() and not ln.startswith("#")]
    if not numbered:
        raise CSVProblem("the file is empty (no data rows)")
    delim = _sniff([ln for _, ln in numbered])
    first = _split(numbered[0][1], delim)
    try:
        [float(c) for c in first]
        header = [f"col{j + 1}" for j in range(len(first))]
        body = numbered
    except ValueError:
        header = [c or f"col{j + 1}" for j, c in enumerate(first)]
        body = numbered[1:]
    if not body:
        raise CSVProblem("the file has a header but no data rows", line=numbered[0][0])
    if len(body) > max_samples:
        raise CSVProblem(f"the file has {len(body)} rows; at most {max_samples} are allowed")
    ncol = len(header)
    out = np.empty((len(body), ncol))
    for k, (lineno, ln) in enumerate(body):
        cells = _split(ln, delim)
        if len(cells) != ncol:
            raise CSVProblem(
                f"line {lineno} has {len(cells)} columns, the header has {ncol}", line=lineno
            )
        for j, c in enumerate(cells):
            try:
                v = float(c)
            except ValueError:
                raise CSVProblem(
                    f"line {lineno}, column {header[j]!r} (column {j}): {c!r} is not a number",
                    line=lineno,
                    column=j,
                ) from None
            if not np.isfinite(v):
                raise CSVProblem(
                    f"line {lineno}, column {header[j]!r} (column {j}): value is not finite",
                    line=lineno,
                    column=j,
                )
            out[k, j] = v
    return header, out


def _col(header: list[str], spec: str | int | None, default: int | None) -> int | None:
    if spec is None or spec == "":
        return default
    if isinstance(spec, int) or (isinstance(spec, str) and spec.isdigit()):
        j = int(spec)
        if not 0 <= j < len(header):
            raise CSVProblem(f"column index {j} out of range (0..{len(header) - 1})")
        return j
    low = [h.lower() for h in header]
    if spec.lower() not in low:
        raise CSVProblem(f"no column named {spec!r}; columns are {', '.join(header)}")
    return low.index(spec.lower())


def recording_from_csv(
    text: str,
    *,
    t_col: str | int | None = None,
    u_col: str | int | None = None,
    y_col: str | int | None = None,
    dt: float = 1e-3,
    max_samples: int = 200_000,
    name: str = "upload.csv",
) -> Recording:
    """Build a :class:`Recording` from CSV text with a column mapping.

    Without a mapping, columns named ``t``/``time``, ``u``/``input`` and ``y``/``output``
    are used, else the columns in order (``t, u, y`` for three or more, ``u, y`` for two,
    with ``t = k * dt``).

    With :mod:`core.csvio` the core reader does the work (delimiter, decimal comma,
    header, unit suffixes, preambles; the first run when the file holds several); the
    built-in parser below is the fallback.

    Raises
    ------
    CSVProblem
        On unreadable content or a mapping that names a missing column.
    """
    mod = optional("core.csvio")
    if mod is not None and hasattr(mod, "read_csv"):
        return _core_recording(mod, text, t_col, u_col, y_col, dt, max_samples, name)
    header, tab = parse_table(text, max_samples)
    low = [h.lower() for h in header]

    def guess(names: tuple[str, ...]) -> int | None:
        for nm in names:
            if nm in low:
                return low.index(nm)
        return None

    gt, gu, gy = guess(("t", "time", "t_s", "time_s")), guess(("u", "input", "v")), guess(
        ("y", "output", "x", "displacement")
    )
    if gu is None or gy is None:
        if len(header) >= 3:
            gt, gu, gy = 0, 1, 2
        elif len(header) == 2:
            gt, gu, gy = None, 0, 1
        else:
            raise CSVProblem("need at least two columns (input u and output y)")
    jt, ju, jy = _col(header, t_col, gt), _col(header, u_col, gu), _col(header, y_col, gy)
    if ju is None or jy is None:
        raise CSVProblem("map the input (u) and output (y) columns")
    if tab.shape[0] < 3:
        raise CSVProblem("need at least 3 samples")
    t = tab[:, jt] if jt is not None else np.arange(tab.shape[0]) * dt
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise CSVProblem(f"time column is not strictly increasing at data row {k + 2}")
    return Recording(t=t.copy(), u=tab[:, ju].copy(), y=tab[:, jy].copy(), name=name)


def _spec(c: str | int | None) -> str | int | None:
    if c is None or c == "":
        return None
    return int(c) if isinstance(c, int) or str(c).isdigit() else str(c)


def _csv_problem(exc: Exception) -> CSVProblem:
    col = getattr(exc, "column_index", None)
    return CSVProblem(str(exc), line=getattr(exc, "line", None),
                      column=None if col is None else int(col))


def _core_recording(mod: ModuleType, text: str, t_col: Any, u_col: Any, y_col: Any, dt: float,
                    max_samples: int, name: str) -> Recording:
    try:
        recs = mod.read_csv(text, time=_spec(t_col), input=_spec(u_col), output=_spec(y_col),
                            name=name, max_rows=max_samples)
    except ParameterError as exc:
        raise _csv_problem(exc) from None
    rec = recs[0]
    t = np.asarray(rec.t, dtype=np.float64)
    cols = getattr(rec, "columns", {}) or {}
    if cols.get("time") is None:
        t = np.arange(t.size) * dt
    label = name if len(recs) == 1 else f"{name} (run 1 of {len(recs)})"
    return Recording(t=t, u=np.asarray(rec.u, dtype=np.float64),
                     y=np.asarray(rec.y, dtype=np.float64), name=label)


def csv_preview(text: str, max_samples: int, rows: int = 5) -> dict[str, Any]:
    """Header, the first ``rows`` rows and the row count of a CSV (mapping step)."""
    mod = optional("core.csvio")
    if mod is not None and hasattr(mod, "inspect_csv"):
        try:
            lay = mod.inspect_csv(text, max_rows=max_samples)
        except ParameterError as exc:
            raise _csv_problem(exc) from None
        lines = text.splitlines()[lay.first_data_line - 1: lay.first_data_line - 1 + rows]
        d = None if lay.delimiter == "whitespace" else lay.delimiter
        return {"columns": [c.raw for c in lay.columns],
                "rows": [[c.strip() for c in (ln.split(d) if d else ln.split())] for ln in lines],
                "n_rows": int(lay.n_rows), "notes": list(lay.notes)}
    header, tab = parse_table(text, max_samples)
    return {"columns": header, "rows": tab[:rows].tolist(), "n_rows": int(tab.shape[0])}


#: Model kinds the explorer can fit, and the :mod:`core.fitting` estimator of each.
FIT_KINDS: dict[str, str] = {
    "pi": "PIRegressor",
    "gpi-deadzone": "DeadZoneGPIRegressor",
    "mpi": "ModifiedPIRegressor",
    "gpi-tanh": "TanhGPIRegressor",
    "digitized": "DigitizedPIRegressor",
}


def fit_kinds() -> list[str]:
    """Fit kinds available now (``pi`` always, the others with :mod:`core.fitting`)."""
    mod = optional("core.fitting")
    return [k for k, c in FIT_KINDS.items() if k == "pi" or hasattr(mod, c)]


def fit_recording(rec: Recording, n: int, kind: str = "pi") -> tuple[Model, dict[str, Any]]:
    """Fit a model of ``kind`` with ``n`` operators to ``rec``; returns ``(model, report)``.

    Uses the :mod:`core.fitting` estimator of :data:`FIT_KINDS` (the model includes the
    fitted output offset, as a chain); without it, for ``pi`` only, a bounded linear
    least-squares fit (``p0, p_i >= 0``) on thresholds ``r_i = i * max|u| / (n + 1)``.
    """
    if kind not in fit_kinds():
        raise ParameterError(f"fit kind {kind!r} is not available; use one of {fit_kinds()}")
    mod = optional("core.fitting")
    reg_cls = getattr(mod, FIT_KINDS[kind], None) if mod is not None else None
    if reg_cls is not None:
        import inspect

        params = inspect.signature(reg_cls).parameters
        key = next((k for k in ("n_operators", "n", "n_thresholds") if k in params), None)
        est = reg_cls(**({key: n} if key else {}))
        est.fit(rec.u, rec.y)
        rep = getattr(est, "report_", None)
        report = rep.to_dict() if hasattr(rep, "to_dict") else {}
        model = getattr(est, "full_model_", None) or est.model_
    else:
        from scipy.optimize import lsq_linear

        from core.operators import play_bank

        umax = float(np.max(np.abs(rec.u))) or 1.0
        r = umax * np.arange(1, n + 1) / (n + 1)
        Z = np.asarray(play_bank(rec.u, r, np.zeros(n))[0])
        A = np.column_stack((rec.u, Z))
        sol = lsq_linear(A, rec.y, bounds=(0.0, np.inf))
        p0 = max(float(sol.x[0]), 1e-9)
        model = PIModel(p0, r, sol.x[1:])
        report = {"method": "bounded least squares (explorer fallback)"}
    y_fit = model(rec.u)
    res = rec.y - y_fit
    rng = float(np.ptp(rec.y)) or 1.0
    report = {
        **_jsonable(report),
        "rms_error": float(np.sqrt(np.mean(res**2))),
        "max_error": float(np.max(np.abs(res))),
        "nrmse_percent": float(100 * np.sqrt(np.mean(res**2)) / rng),
        "n_operators": int(n),
        "kind": kind,
    }
    return model, report


def _jsonable(x: Any) -> Any:
    """Numpy scalars/arrays inside ``x`` converted to plain JSON types."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, float) and not np.isfinite(x):
        return None
    return x


def diagnosis_html(result: Any) -> str | None:
    """The self-contained HTML report (``app.diagnosis_report``) of a diagnosis result."""
    res = result
    mod = optional("app.diagnosis_report")
    if res is None or mod is None or not hasattr(mod, "write_report"):
        return None
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as tmp:
        path = mod.write_report(res, Path(tmp) / "report.html")
        return Path(path).read_text(encoding="utf-8")


def _diagnosis_summary(d: dict[str, Any]) -> dict[str, Any]:
    """Findings (accepted effects, ambiguities, untestable effects) of a diagnosis document."""
    findings: list[str] = []
    for e in d.get("effects", []):
        params = ", ".join(f"{k} = {v:.4g}" for k, v in (e.get("parameters") or {}).items()
                           if isinstance(v, int | float))
        where = (e.get("where") or {}).get("summary", "")
        findings.append(f"{e.get('name')} ({e.get('family', '')}): {params}. {where}".strip())
    if not findings:
        findings.append("no missing physics detected: the PI model explains the data")
    for a in d.get("ambiguous", []):
        findings.append(f"ambiguous {' vs '.join(a.get('effects', []))}: {a.get('experiment', '')}")
    for u in d.get("untestable", []):
        findings.append(f"untestable {u.get('name')}: {u.get('reason', '')}")
    base, final = d.get("baseline", {}), d.get("final", {})
    return {
        "findings": findings,
        "baseline_rmse_pct": base.get("heldout_rmse_pct"),
        "final_rmse_pct": final.get("heldout_rmse_pct"),
        "effects": final.get("effects", []),
    }


def diagnose_recording(rec: Recording, model: Model) -> dict[str, Any]:
    """Diagnosis report of ``model`` against ``rec`` (see :func:`run_diagnosis`)."""
    return run_diagnosis(rec, model)[0]


def run_diagnosis(rec: Recording, model: Model) -> tuple[dict[str, Any], Any]:
    """Diagnosis of ``rec`` (``core.diagnosis`` when available): ``(report, result)``.

    ``result`` is the core's ``DiagnosisResult`` (``None`` for the fallback); the report
    holds the findings, the held-out RMSE before and after, and the core's JSON document.

    The fallback reports residual statistics and two simple signatures: a residual that
    correlates with the input's rate (dynamics / creep) and one that correlates with
    ``u²`` (asymmetry, missing dead-zone map).
    """
    mod = optional("core.diagnosis")
    fn = getattr(mod, "diagnose", None) if mod is not None else None
    if fn is not None:
        pi = pi_part(model)
        n = int(min(25, max(4, pi.n if pi is not None else 10)))
        result = fn((rec.t, rec.u, rec.y), "pi", n_operators=n)
        d = _jsonable(result.to_dict())
        return {"engine": "core.diagnosis", **_diagnosis_summary(d), "document": d}, result
    y_fit = model(rec.u)
    res = rec.y - y_fit
    du = np.gradient(rec.u, rec.t)

    def corr(a: np.ndarray, b: np.ndarray) -> float:
        sa, sb = float(np.std(a)), float(np.std(b))
        return 0.0 if sa == 0 or sb == 0 else float(np.corrcoef(a, b)[0, 1])

    c_rate, c_sq = corr(res, du), corr(res, rec.u**2)
    findings = []
    rel = float(np.sqrt(np.mean(res**2))) / (float(np.ptp(rec.y)) or 1.0)
    if rel < 0.005:
        c_rate = c_sq = 0.0
    if abs(c_rate) > 0.3:
        findings.append(f"residual correlates with du/dt (ρ = {c_rate:.2f}): rate dependence")
    if abs(c_sq) > 0.3:
        findings.append(f"residual correlates with u² (ρ = {c_sq:.2f}): asymmetric loop")
    if not findings:
        findings.append("no strong residual signature: the PI model explains the data")
    return {
        "engine": "explorer fallback (core.diagnosis not installed)",
        "rms_error": float(np.sqrt(np.mean(res**2))),
        "max_error": float(np.max(np.abs(res))),
        "corr_rate": c_rate,
        "corr_u_squared": c_sq,
        "findings": findings,
    }, None


# ----------------------------------------------------------------------------- presets
def _fallback_presets() -> dict[str, dict[str, Any]]:
    ex1 = PIModel.from_dict(EXAMPLE1)
    return {
        "paper001-example1": {
            "name": "paper001-example1",
            "title": "Paper 001 Example 1: classical PI, 6 operators",
            "model": dict(EXAMPLE1),
        },
        "paper001-example2": {
            "name": "paper001-example2",
            "title": "Paper 001 Example 2: inverse of Example 1",
            "model": ex1.inverse().to_dict(),
        },
    }


def preset_names() -> list[str]:
    """Names of the presets (``core.presets`` when available, else built-ins)."""
    mod = optional("core.presets")
    if mod is not None and hasattr(mod, "list_presets"):
        out = []
        for p in mod.list_presets():
            out.append(p if isinstance(p, str) else getattr(p, "name", str(p)))
        return out
    return list(_fallback_presets())


def get_preset(name: str) -> dict[str, Any]:
    """``{"name", "title", "model", ...}`` of preset ``name``; ``KeyError`` if unknown."""
    mod = optional("core.presets")
    if mod is not None and hasattr(mod, "get_preset"):
        try:
            p = mod.get_preset(name)
        except (KeyError, ValueError) as exc:
            raise KeyError(name) from exc
        doc = _preset_doc(name, p)
        for info in mod.list_presets():
            if getattr(info, "name", None) == name:
                doc["title"] = str(getattr(info, "title", name))
                doc["description"] = str(getattr(info, "description", ""))
        return doc
    return _fallback_presets()[name]


def _preset_doc(name: str, p: Any) -> dict[str, Any]:
    """Normalise whatever ``core.presets.get_preset`` returns to a JSON document."""
    if isinstance(p, Model):
        return {"name": name, "title": name, "model": p.to_dict()}
    if isinstance(p, dict):
        d = dict(p)
    else:
        d = {k: getattr(p, k) for k in dir(p) if not k.startswith("_") and not callable(
            getattr(p, k))}
    model = d.get("model")
    if isinstance(model, Model):
        model = model.to_dict()
    if model is None and "type" in d:
        model = {k: v for k, v in d.items() if k not in ("name", "title", "description")}
    out: dict[str, Any] = {
        "name": name,
        "title": str(d.get("title") or d.get("description") or name),
        "model": _jsonable(model),
    }
    sig = d.get("signal") or d.get("input")
    if isinstance(sig, dict):
        out["signal"] = _jsonable(sig)
    return out


# ----------------------------------------------------------------------------- export
PARAMSET_SCHEMA = "hysteresis-explorer/parameter-set"


def export_formats() -> list[str]:
    """Download formats of a parameter set."""
    return ["json", "mat", "c"]


def _paramset(model: Model, fit: dict[str, Any] | None = None) -> Any:
    mod = optional("core.paramset")
    ps = getattr(mod, "ParameterSet", None) if mod is not None else None
    if ps is None:
        return None
    return ps.from_model(model, source="hysteresis explorer", fit=fit)


def parameter_set_doc(model: Model, code: str = "", fit: dict[str, Any] | None = None) -> dict:
    """The JSON parameter-set document of ``model`` (``core.paramset`` when available)."""
    ps = _paramset(model, fit)
    if ps is not None:
        return ps.to_dict()
    return {"format": PARAMSET_SCHEMA, "version": 1, "session": code, "model": model.to_dict()}


def parameter_set_model(doc: Any) -> Model:
    """The model inside a parameter-set document (``core.paramset`` format, or a bare model).

    Raises
    ------
    ParameterError
        If the document is malformed (the message names the JSON path).
    """
    if not isinstance(doc, dict):
        raise ParameterError("a parameter set must be a JSON object")
    mod = optional("core.paramset")
    loader = getattr(mod, "load_parameter_set", None) if mod is not None else None
    if loader is not None and "format" in doc:
        return loader(doc).model
    if mod is not None and hasattr(mod, "ensure_model_types_registered"):
        mod.ensure_model_types_registered()
    return model_from_dict(doc["model"] if "model" in doc else doc)


def export_bytes(
    model: Model, fmt: str, code: str = "", fit: dict[str, Any] | None = None
) -> tuple[str, bytes]:
    """``(filename, content)`` of ``model`` exported as ``json``, ``mat`` or ``c``.

    ``c`` is one file: the generated header followed by the source (``core.export_c``
    generates the inverse compensator and the forward model when the model is invertible,
    the forward model only otherwise).
    """
    import io
    import json
    import tempfile
    from pathlib import Path

    stem = f"hysteresis-{model.type_name}{'-' + code if code else ''}"
    if fmt == "json":
        doc = parameter_set_doc(model, code, fit)
        return f"{stem}.json", json.dumps(_jsonable(doc), indent=2).encode()
    if fmt == "mat":
        mod = optional("core.export_mat")
        if mod is not None:
            with tempfile.TemporaryDirectory() as tmp:
                path = mod.export_mat(_paramset(model, fit) or model, Path(tmp) / "p.mat")
                return f"{stem}.mat", Path(path).read_bytes()
        from scipy.io import savemat

        buf = io.BytesIO()
        savemat(buf, _mat_fields(model))
        return f"{stem}.mat", buf.getvalue()
    if fmt == "c":
        mod = optional("core.export_c")
        if mod is not None:
            try:
                model.inverse()
                inv = True
            except (NotInvertibleError, ParameterError):
                inv = False
            note = ""
            try:
                cc = mod.generate_c(model, "hyst", inverse=inv, forward=True)
            except ParameterError:
                pi = pi_part(model)
                if pi is None or pi is model:
                    raise
                cc = mod.generate_c(pi, "hyst", inverse=pi.is_invertible, forward=True)
                rest = [s.to_dict() for s in getattr(model, "stages", ()) if s is not pi]
                note = f"/* NOTE: only the PI stage is exported; other stages: {rest} */\n"
            src = cc.source.replace(f'#include "{cc.name}.h"', f'/* {cc.name}.h inlined above */')
            text = note + (
                f"/* ===== {cc.name}.h ===== */\n{cc.header}\n"
                f"/* ===== {cc.name}.c ===== */\n{src}"
            )
            return f"{stem}.c", text.encode()
        return f"{stem}.c", _c_source(model).encode()
    raise ParameterError(f"unknown export format {fmt!r}; known: {export_formats()}")


def _mat_fields(model: Model) -> dict[str, Any]:
    d = model.to_dict()
    out: dict[str, Any] = {"model_type": d["type"]}
    for k, v in d.items():
        if isinstance(v, int | float | list) and k != "type":
            try:
                out[k] = np.asarray(v, dtype=np.float64)
            except (TypeError, ValueError):
                continue
    return out


def _c_source(model: Model) -> str:
    """A self-contained C implementation of a classical PI model (fallback exporter)."""
    if not isinstance(model, PIModel):
        raise ParameterError("the built-in C exporter handles the classical PI model only")

    def arr(x: np.ndarray) -> str:
        return ", ".join(f"{v:.17g}" for v in x)

    n = model.n
    return f"""/* Prandtl-Ishlinskii model exported by Hysteresis Explorer.
 * y = p0*u + sum_i p_i * play_{{r_i}}(u); call pi_step once per sample. */
#define PI_N {n}
static const double pi_p0 = {model.p0:.17g};
static const double pi_r[PI_N] = {{ {arr(model.thresholds)} }};
static const double pi_p[PI_N] = {{ {arr(model.weights)} }};
static double pi_z[PI_N] = {{ {arr(model.state0)} }};

double pi_step(double u)
{{
    double y = pi_p0 * u;
    for (int i = 0; i < PI_N; ++i) {{
        double lo = u - pi_r[i], hi = u + pi_r[i];
        double z = pi_z[i];
        z = z < lo ? lo : (z > hi ? hi : z);
        pi_z[i] = z;
        y += pi_p[i] * z;
    }}
    return y;
}}
"""
