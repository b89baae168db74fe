"""Input signals for teaching and testing hysteresis models.

Every generator returns ``(t, u)``: sample times ``t`` in seconds, starting at 0 and spaced
``1 / sample_rate``, and the input ``u`` in the model's input units (V, µm, ... — whatever
``amplitude`` and ``offset`` are given in). Both arrays have shape ``(N,)`` with
``N = round(duration * sample_rate) + 1`` (the end point is included), except for the
staircase, whose duration follows from its number of levels and hold time.

:data:`SIGNALS` lists the generators by name with parameter specifications (default, range,
unit), so the CLI and the browser explorer can offer them without knowing each function::

    >>> t, u = build_signal("sine", amplitude=4.0, frequency=1.0, duration=1.0)
    >>> round(float(u.max()), 6)
    4.0
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np

from ._typing import Float1D
from .exceptions import ParameterError

__all__ = [
    "MAX_SAMPLES",
    "SIGNALS",
    "ParamSpec",
    "SignalSpec",
    "build_signal",
    "chirp",
    "decaying_sine",
    "list_signals",
    "multisine",
    "random_reversals",
    "sine",
    "staircase",
    "time_vector",
    "triangle",
]

#: Largest number of samples a generator will produce (guards against typos such as
#: ``sample_rate=1e9``); 2e7 samples are 160 MB per array.
MAX_SAMPLES = 20_000_000


# --------------------------------------------------------------------------- validation
def _number(x: object, name: str) -> float:
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a number, got {x!r}") from exc
    if not math.isfinite(v):
        raise ParameterError(f"{name} = {v} is not finite; it must be a number")
    return v


def _positive(x: object, name: str, unit: str = "") -> float:
    v = _number(x, name)
    if v <= 0:
        raise ParameterError(f"{name} = {v:g}{unit} must be > 0")
    return v


def _nonnegative(x: object, name: str, unit: str = "") -> float:
    v = _number(x, name)
    if v < 0:
        raise ParameterError(f"{name} = {v:g}{unit} must be >= 0")
    return v


def _count(x: object, name: str, minimum: int = 1) -> int:
    if isinstance(x, bool):
        raise ParameterError(f"{name} must be an integer, got {x!r}")
    v = _number(x, name)
    if v != int(v):
        raise ParameterError(f"{name} = {v:g} must be an integer")
    if v < minimum:
        raise ParameterError(f"{name} = {int(v)} must be >= {minimum}")
    return int(v)


def _nyquist(frequency: float, sample_rate: float, name: str = "frequency") -> None:
    if frequency >= sample_rate / 2:
        raise ParameterError(
            f"{name} = {frequency:g} Hz must be below half the sample_rate "
            f"({sample_rate / 2:g} Hz, Nyquist); raise sample_rate"
        )


def time_vector(duration: float, sample_rate: float) -> Float1D:
    """Sample times ``0, 1/fs, ..., duration`` in seconds.

    Parameters
    ----------
    duration : float
        Length of the record in seconds, > 0.
    sample_rate : float
        Samples per second (Hz), > 0.

    Returns
    -------
    ndarray of shape (N,)
        ``N = round(duration * sample_rate) + 1``.

    Raises
    ------
    ParameterError
        If ``duration`` or ``sample_rate`` is not positive, or ``N > MAX_SAMPLES``.
    """
    duration = _positive(duration, "duration", " s")
    sample_rate = _positive(sample_rate, "sample_rate", " Hz")
    n = int(round(duration * sample_rate)) + 1
    if n > MAX_SAMPLES:
        raise ParameterError(
            f"duration * sample_rate = {duration * sample_rate:g} samples exceeds the limit "
            f"of {MAX_SAMPLES}; shorten duration or lower sample_rate"
        )
    return np.arange(n) / sample_rate


# --------------------------------------------------------------------------- generators
def sine(
    amplitude: float = 1.0,
    frequency: float = 1.0,
    offset: float = 0.0,
    duration: float = 1.0,
    sample_rate: float = 1000.0,
    phase: float = 0.0,
) -> tuple[Float1D, Float1D]:
    """``u = offset + amplitude * sin(2π f t + phase)``.

    Parameters
    ----------
    amplitude : float
        Peak amplitude (input units), >= 0.
    frequency : float
        Frequency in Hz, > 0 and below ``sample_rate / 2``.
    offset : float
        Constant added to the signal (input units).
    duration : float
        Seconds, > 0.
    sample_rate : float
        Samples per second (Hz), > 0.
    phase : float
        Phase at ``t = 0`` in radians.

    Returns
    -------
    t, u : ndarray of shape (N,)
    """
    amplitude = _nonnegative(amplitude, "amplitude")
    frequency = _positive(frequency, "frequency", " Hz")
    phase = _number(phase, "phase")
    return multisine([amplitude], [frequency], [phase], offset, duration, sample_rate)


def multisine(
    amplitudes: Sequence[float] = (5.85, 2.35),
    frequencies: Sequence[float] = (1.0, 5.0),
    phases: Sequence[float] | None = None,
    offset: float = 0.0,
    duration: float = 1.0,
    sample_rate: float = 1000.0,
) -> tuple[Float1D, Float1D]:
    """Sum of sines ``offset + Σ_k a_k sin(2π f_k t + φ_k)``.

    The defaults are paper 001's Example 3 input, ``5.85 sin 2πt + 2.35 sin 10πt``.

    Parameters
    ----------
    amplitudes : sequence of float, length K
        Peak amplitude of each component (input units), >= 0.
    frequencies : sequence of float, length K
        Frequency of each component in Hz, > 0 and below ``sample_rate / 2``.
    phases : sequence of float, length K, optional
        Phases in radians (zeros by default).
    offset, duration, sample_rate : float
        As in :func:`sine`.

    Returns
    -------
    t, u : ndarray of shape (N,)

    Raises
    ------
    ParameterError
        If the sequences are empty or of different lengths, or a value breaks its rule.
    """
    a = [_nonnegative(x, f"amplitudes[{i}]") for i, x in enumerate(amplitudes)]
    f = [_positive(x, f"frequencies[{i}]", " Hz") for i, x in enumerate(frequencies)]
    if not a:
        raise ParameterError("amplitudes must have at least one component")
    if len(a) != len(f):
        raise ParameterError(
            f"amplitudes has {len(a)} entries but frequencies has {len(f)}; one of each "
            "per component"
        )
    ph = [0.0] * len(a) if phases is None else [
        _number(x, f"phases[{i}]") for i, x in enumerate(phases)
    ]
    if len(ph) != len(a):
        raise ParameterError(f"phases has {len(ph)} entries but there are {len(a)} components")
    offset = _number(offset, "offset")
    t = time_vector(duration, sample_rate)
    for i, fi in enumerate(f):
        _nyquist(fi, float(sample_rate), f"frequencies[{i}]" if len(f) > 1 else "frequency")
    u = np.full(t.size, offset)
    for ai, fi, pi in zip(a, f, ph, strict=True):
        u += ai * np.sin(2.0 * np.pi * fi * t + pi)
    return t, u


def decaying_sine(
    amplitude: float = 4.0,
    frequency: float = 1.0,
    decay_time: float = 2.0,
    offset: float = 0.0,
    duration: float = 6.0,
    sample_rate: float = 1000.0,
) -> tuple[Float1D, Float1D]:
    """Exponentially decaying sine ``offset + A exp(-t/τ) sin(2π f t)``: nested minor loops.

    Parameters
    ----------
    amplitude : float
        Initial peak amplitude (input units), >= 0.
    frequency : float
        Hz, > 0.
    decay_time : float
        Time constant τ of the envelope in seconds, > 0.
    offset, duration, sample_rate : float
        As in :func:`sine`.

    Returns
    -------
    t, u : ndarray of shape (N,)
    """
    amplitude = _nonnegative(amplitude, "amplitude")
    frequency = _positive(frequency, "frequency", " Hz")
    tau = _positive(decay_time, "decay_time", " s")
    offset = _number(offset, "offset")
    t = time_vector(duration, sample_rate)
    _nyquist(frequency, float(sample_rate))
    return t, offset + amplitude * np.exp(-t / tau) * np.sin(2.0 * np.pi * frequency * t)


def triangle(
    amplitude: float = 1.0,
    frequency: float = 1.0,
    offset: float = 0.0,
    duration: float = 1.0,
    sample_rate: float = 1000.0,
) -> tuple[Float1D, Float1D]:
    """Symmetric triangle wave starting at ``offset`` and rising first (same phase as a sine).

    Piecewise linear with turning points ``offset ± amplitude`` at ``t = (1/4 + k/2) / f``;
    the constant rate makes it the natural input for rate-independence checks.

    Parameters
    ----------
    amplitude, frequency, offset, duration, sample_rate : float
        As in :func:`sine`.

    Returns
    -------
    t, u : ndarray of shape (N,)
    """
    amplitude = _nonnegative(amplitude, "amplitude")
    frequency = _positive(frequency, "frequency", " Hz")
    offset = _number(offset, "offset")
    t = time_vector(duration, sample_rate)
    _nyquist(frequency, float(sample_rate))
    x = (t * frequency + 0.25) % 1.0  # phase in cycles, shifted so x = 0.25 at t = 0
    tri = 1.0 - 4.0 * np.abs(x - 0.5)  # -1 at x=0, +1 at x=0.5, 0 at x=0.25
    return t, offset + amplitude * tri


def staircase(
    amplitude: float = 1.0,
    steps: int = 10,
    hold: float = 0.1,
    offset: float = 0.0,
    sample_rate: float = 1000.0,
    up_down: bool = True,
) -> tuple[Float1D, Float1D]:
    """Quasi-static staircase: levels held constant, as in a point-by-point measurement.

    The levels go from ``offset`` up to ``offset + amplitude`` in ``steps`` equal steps; with
    ``up_down`` they then go down to ``offset - amplitude`` and back up to ``offset + amplitude``
    (``2 * steps`` steps each way), which traces the ascending and descending branches of
    the major loop. Each level is held for ``hold`` seconds.

    Parameters
    ----------
    amplitude : float
        Largest excursion from ``offset`` (input units), >= 0.
    steps : int
        Number of steps from ``offset`` to the top, >= 1.
    hold : float
        Seconds each level is held, >= 1/sample_rate.
    offset : float
        Start level (input units).
    sample_rate : float
        Hz, > 0.
    up_down : bool
        Add the descending and the second ascending sweep.

    Returns
    -------
    t, u : ndarray of shape (N,)
        ``N = levels * round(hold * sample_rate)``.
    """
    amplitude = _nonnegative(amplitude, "amplitude")
    steps = _count(steps, "steps")
    hold = _positive(hold, "hold", " s")
    offset = _number(offset, "offset")
    sample_rate = _positive(sample_rate, "sample_rate", " Hz")
    per = int(round(hold * sample_rate))
    if per < 1:
        raise ParameterError(
            f"hold = {hold:g} s is shorter than one sample (1/sample_rate = "
            f"{1 / sample_rate:g} s)"
        )
    k = np.arange(steps + 1) / steps
    levels = [k]
    if up_down:
        down = 1.0 - np.arange(1, 2 * steps + 1) / steps  # 1 - 1/s ... -1
        up = -1.0 + np.arange(1, 2 * steps + 1) / steps
        levels += [down, up]
    lv = offset + amplitude * np.concatenate(levels)
    n = lv.size * per
    if n > MAX_SAMPLES:
        raise ParameterError(
            f"staircase would have {n} samples (> {MAX_SAMPLES}); lower steps, hold or "
            "sample_rate"
        )
    u = np.repeat(lv, per)
    return np.arange(n) / sample_rate, u


def chirp(
    amplitude: float = 1.0,
    f0: float = 0.5,
    f1: float = 20.0,
    offset: float = 0.0,
    duration: float = 4.0,
    sample_rate: float = 1000.0,
) -> tuple[Float1D, Float1D]:
    """Linear chirp ``offset + A sin(2π (f0 t + (f1 - f0) t² / (2T)))``.

    The instantaneous frequency sweeps linearly from ``f0`` to ``f1`` Hz over ``T = duration``;
    useful to expose rate-dependent (dynamic) effects that a PI model cannot represent.

    Parameters
    ----------
    amplitude : float
        Peak amplitude (input units), >= 0.
    f0, f1 : float
        Start and end frequency in Hz, > 0 and below ``sample_rate / 2``.
    offset, duration, sample_rate : float
        As in :func:`sine`.

    Returns
    -------
    t, u : ndarray of shape (N,)
    """
    amplitude = _nonnegative(amplitude, "amplitude")
    f0 = _positive(f0, "f0", " Hz")
    f1 = _positive(f1, "f1", " Hz")
    offset = _number(offset, "offset")
    t = time_vector(duration, sample_rate)
    _nyquist(f0, float(sample_rate), "f0")
    _nyquist(f1, float(sample_rate), "f1")
    T = float(duration)
    phase = 2.0 * np.pi * (f0 * t + (f1 - f0) * t**2 / (2.0 * T))
    return t, offset + amplitude * np.sin(phase)


def random_reversals(
    amplitude: float = 1.0,
    reversals: int = 20,
    offset: float = 0.0,
    duration: float = 2.0,
    sample_rate: float = 1000.0,
    seed: int = 0,
) -> tuple[Float1D, Float1D]:
    """Piecewise-linear input through random turning points (reproducible with ``seed``).

    Starting at ``offset``, the input alternately rises and falls to random extremes within
    ``offset ± amplitude``; each extreme is drawn uniformly between the current value and
    the bound in the current direction, so the direction really reverses at every knot.
    Knots are equally spaced in time, ``duration / (reversals + 1)`` apart, and the final
    segment ends at a random value.

    Parameters
    ----------
    amplitude : float
        Bound of the excursions around ``offset`` (input units), >= 0.
    reversals : int
        Number of turning points, >= 1.
    offset, duration, sample_rate : float
        As in :func:`sine`.
    seed : int
        Seed of ``numpy.random.default_rng``.

    Returns
    -------
    t, u : ndarray of shape (N,)
    """
    amplitude = _nonnegative(amplitude, "amplitude")
    reversals = _count(reversals, "reversals")
    offset = _number(offset, "offset")
    seed = _count(seed, "seed", minimum=0)
    t = time_vector(duration, sample_rate)
    rng = np.random.default_rng(seed)
    knots = np.empty(reversals + 2)
    knots[0] = 0.0
    x, up = 0.0, True
    for k in range(1, reversals + 2):
        frac = rng.uniform(0.2, 1.0)  # travel at least 20 % of the way to the bound
        x = x + frac * ((1.0 if up else -1.0) - x)
        knots[k] = x
        up = not up
    tk = np.linspace(0.0, float(t[-1]), reversals + 2)
    return t, offset + amplitude * np.interp(t, tk, knots)


# --------------------------------------------------------------------------- registry
@dataclass(frozen=True, eq=False)
class ParamSpec:
    """One parameter of a signal generator, for building forms and sliders.

    Parameters
    ----------
    name : str
        Keyword argument name.
    default : float, int or bool
        Default value.
    minimum, maximum : float
        Inclusive range offered by user interfaces (and checked by :func:`build_signal`).
    unit : str
        Unit shown next to the value (``"s"``, ``"Hz"``, ``"input"`` for input units).
    kind : {"float", "int", "bool"}
        Value type.
    description : str
        One line of help.
    """

    name: str
    default: float | int | bool
    minimum: float = -math.inf
    maximum: float = math.inf
    unit: str = ""
    kind: str = "float"
    description: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ("float", "int", "bool"):
            raise ParameterError(f"ParamSpec.kind = {self.kind!r} must be float, int or bool")
        if not self.minimum <= self.maximum:
            raise ParameterError(
                f"ParamSpec {self.name}: minimum {self.minimum} must be <= maximum {self.maximum}"
            )

    def coerce(self, value: Any) -> float | int | bool:
        """Convert ``value`` to this parameter's kind and check the range.

        Raises
        ------
        ParameterError
            Naming the parameter and the allowed range.
        """
        if self.kind == "bool":
            if isinstance(value, str):
                low = value.strip().lower()
                if low in ("1", "true", "yes", "on"):
                    return True
                if low in ("0", "false", "no", "off"):
                    return False
                raise ParameterError(f"{self.name} must be true or false, got {value!r}")
            return bool(value)
        v = _number(value, self.name)
        if self.kind == "int":
            if v != int(v):
                raise ParameterError(f"{self.name} = {v:g} must be an integer")
            v = int(v)
        if not self.minimum <= v <= self.maximum:
            raise ParameterError(
                f"{self.name} = {v:g} is outside the allowed range "
                f"[{self.minimum:g}, {self.maximum:g}]{' ' + self.unit if self.unit else ''}"
            )
        return v

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (infinite bounds become ``None``)."""
        return {
            "name": self.name,
            "default": self.default,
            "min": None if math.isinf(self.minimum) else self.minimum,
            "max": None if math.isinf(self.maximum) else self.maximum,
            "unit": self.unit,
            "kind": self.kind,
            "description": self.description,
        }


@dataclass(frozen=True, eq=False)
class SignalSpec:
    """A named signal generator and its parameters.

    Parameters
    ----------
    name : str
        Registry key.
    title : str
        Human-readable title.
    function : callable
        ``function(**params) -> (t, u)``.
    params : tuple of ParamSpec
        Every keyword the function accepts through the registry.
    description : str
        One paragraph for help texts.
    """

    name: str
    title: str
    function: Callable[..., tuple[Float1D, Float1D]]
    params: tuple[ParamSpec, ...]
    description: str = ""

    def defaults(self) -> dict[str, Any]:
        """``{parameter: default}``."""
        return {p.name: p.default for p in self.params}

    def build(self, **params: Any) -> tuple[Float1D, Float1D]:
        """Generate the signal; unspecified parameters take their defaults.

        Raises
        ------
        ParameterError
            For unknown parameter names (the valid ones are listed) or values out of range.
        """
        specs = {p.name: p for p in self.params}
        unknown = sorted(set(params) - set(specs))
        if unknown:
            raise ParameterError(
                f"signal {self.name!r} has no parameter(s) {', '.join(unknown)}; "
                f"valid: {', '.join(specs)}"
            )
        kw = {name: spec.coerce(params.get(name, spec.default)) for name, spec in specs.items()}
        return self.function(**kw)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description for user interfaces."""
        return {
            "name": self.name,
            "title": self.title,
            "description": self.description,
            "params": [p.to_dict() for p in self.params],
        }


def _amp(default: float = 4.0) -> ParamSpec:
    return ParamSpec("amplitude", default, 0.0, 1e6, "input", "float", "peak amplitude")


def _freq(default: float = 1.0, name: str = "frequency") -> ParamSpec:
    return ParamSpec(name, default, 1e-6, 1e6, "Hz", "float", "frequency")


_OFFSET = ParamSpec("offset", 0.0, -1e6, 1e6, "input", "float", "constant offset")
_FS = ParamSpec("sample_rate", 1000.0, 1e-3, 1e7, "Hz", "float", "samples per second")


def _dur(default: float = 2.0) -> ParamSpec:
    return ParamSpec("duration", default, 1e-6, 1e6, "s", "float", "record length")


def _two_sines(
    amplitude: float, frequency: float, amplitude2: float, frequency2: float,
    offset: float, duration: float, sample_rate: float,
) -> tuple[Float1D, Float1D]:
    return multisine([amplitude, amplitude2], [frequency, frequency2], None, offset, duration,
                     sample_rate)


_SPECS = (
    SignalSpec(
        "sine", "Sine", sine,
        (_amp(), _freq(), _OFFSET, _dur(), _FS,
         ParamSpec("phase", 0.0, -2 * math.pi, 2 * math.pi, "rad", "float", "initial phase")),
        "offset + amplitude sin(2π f t + phase); paper 001 Example 1 uses 4 sin 2πt.",
    ),
    SignalSpec(
        "multisine", "Two-tone sine", _two_sines,
        (_amp(5.85), _freq(1.0),
         ParamSpec("amplitude2", 2.35, 0.0, 1e6, "input", "float", "second amplitude"),
         _freq(5.0, "frequency2"), _OFFSET, _dur(), _FS),
        "Sum of two sines; the defaults are paper 001 Example 3 (5.85 sin 2πt + 2.35 sin 10πt).",
    ),
    SignalSpec(
        "decaying_sine", "Decaying sine (minor loops)", decaying_sine,
        (_amp(), _freq(),
         ParamSpec("decay_time", 2.0, 1e-6, 1e6, "s", "float", "envelope time constant"),
         _OFFSET, _dur(6.0), _FS),
        "A exp(-t/τ) sin(2π f t): a sequence of nested minor loops.",
    ),
    SignalSpec(
        "triangle", "Triangle", triangle, (_amp(), _freq(), _OFFSET, _dur(), _FS),
        "Constant-rate ramps between offset ± amplitude.",
    ),
    SignalSpec(
        "staircase", "Staircase with holds", staircase,
        (_amp(),
         ParamSpec("steps", 10, 1, 10_000, "", "int", "steps from offset to the top"),
         ParamSpec("hold", 0.1, 1e-6, 1e4, "s", "float", "time each level is held"),
         _OFFSET, _FS,
         ParamSpec("up_down", True, 0, 1, "", "bool", "also sweep down and back up")),
        "Quasi-static point-by-point sweep: up to +A, then (optionally) down to -A and up.",
    ),
    SignalSpec(
        "chirp", "Linear chirp", chirp,
        (_amp(), _freq(0.5, "f0"), _freq(20.0, "f1"), _OFFSET, _dur(4.0), _FS),
        "Sine whose frequency sweeps linearly from f0 to f1: reveals rate dependence.",
    ),
    SignalSpec(
        "random_reversals", "Random reversals", random_reversals,
        (_amp(),
         ParamSpec("reversals", 20, 1, 100_000, "", "int", "number of turning points"),
         _OFFSET, _dur(), _FS,
         ParamSpec("seed", 0, 0, 2**32 - 1, "", "int", "random seed")),
        "Piecewise-linear path through random turning points (reproducible by seed).",
    ),
)

#: Registry of signal generators, name → :class:`SignalSpec` (read-only).
SIGNALS: Mapping[str, SignalSpec] = MappingProxyType({s.name: s for s in _SPECS})


def list_signals() -> list[SignalSpec]:
    """Every registered signal generator, in registry order."""
    return list(SIGNALS.values())


def build_signal(name: str, **params: Any) -> tuple[Float1D, Float1D]:
    """Build a registered signal by name.

    Parameters
    ----------
    name : str
        A key of :data:`SIGNALS`.
    **params
        Parameter values (strings are accepted and converted, as from a form or CLI).

    Returns
    -------
    t, u : ndarray of shape (N,)

    Raises
    ------
    ParameterError
        If the name is unknown (the valid names are listed) or a parameter is invalid.
    """
    spec = SIGNALS.get(name)
    if spec is None:
        raise ParameterError(f"unknown signal {name!r}; valid signals: {', '.join(SIGNALS)}")
    return spec.build(**params)
