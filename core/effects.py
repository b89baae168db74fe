"""Effects that classical PI leaves out, each a registered :class:`~core.base.Model`.

Every effect is a stage of the composition algebra, so a diagnosed model is an ordinary
:class:`~core.base.Chain` that simulates, serialises (``to_dict``/``from_dict``) and is
loaded by :func:`core.base.model_from_dict`. The ``type`` names are the effect names used in
the machine-readable diagnosis output (see ``shared/notes/missing-physics.md`` §3):

============== ============================== =====================================================
type           class                          equation (x = stage input, y = stage output)
============== ============================== =====================================================
delay          :class:`Delay`                 ``y(t) = x(t - τ_d)`` (fractional: interpolated)
lag            :class:`Lag`                   ``τ ẏ + y = x`` (first-order lag, unit DC gain)
resonance      :class:`Resonance`             ``ÿ + 2ζω_n ẏ + ω_n² y = ω_n² x``
rate           :class:`RateDependentPI`       PI whose r > 0 thresholds are ``r_i + β|u̇|``
creep          :class:`Creep`                 ``y = x + Σ_j c_j (L_{τ_j}[x] - x)`` (log-spaced lags)
drift          :class:`Drift`                 ``y = x + Σ_k a_k P_k(2t/T - 1)`` (Legendre in time)
asymmetry      :class:`Asymmetry`             ``y = x + Σ_k a_k ((x - c)/s)^k`` (k = 2, 3, ...)
offset         :class:`Offset`                ``y = x + c``
initial-memory :class:`InitialMemory`         hysteresis model started after a virtual input history
============== ============================== =====================================================

Linear dynamics are discretised exactly for a piecewise-linear input (first-order hold), so
they have unit DC gain and the default state is "at rest at the first input sample".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D
from .base import Model, model_from_dict, register_model
from .exceptions import NotInvertibleError, ParameterError
from .pi import PIModel
from .validation import as_finite_scalar, as_input_signal, as_vector, frozen

__all__ = [
    "EFFECT_TYPES",
    "Asymmetry",
    "Creep",
    "Delay",
    "Drift",
    "InitialMemory",
    "Lag",
    "Offset",
    "RateDependentPI",
    "Resonance",
    "foh_filter",
    "rd_play_bank",
]

#: The effect names, in the order the diagnosis reports them.
EFFECT_TYPES: tuple[str, ...] = (
    "delay",
    "lag",
    "resonance",
    "rate",
    "creep",
    "drift",
    "asymmetry",
    "offset",
    "initial-memory",
)


def _need(d: dict[str, Any], *keys: str, kind: str) -> None:
    missing = [k for k in keys if k not in d]
    if missing:
        raise ParameterError(f"{kind} model is missing field(s): {', '.join(missing)}")


# ----------------------------------------------------------------------------- linear filters
def _tf_coefficients(num: list[float], den: list[float], dt: float) -> tuple[Float1D, Float1D]:
    """First-order-hold discretisation of ``num(s)/den(s)`` (exact for piecewise-linear input).

    Memoised on the exact float values (the diagnosis filters thousands of regressor
    columns with a few distinct transfer functions); copies are returned.
    """
    b, a, _ = _tf_memo(num, den, dt)
    return b.copy(), a.copy()


_TF_MEMO: dict[tuple, tuple[Float1D, Float1D, Float1D]] = {}


def _tf_memo(num: list[float], den: list[float], dt: float) -> tuple[Float1D, Float1D, Float1D]:
    """``(b, a, lfilter_zi(b, a))``, memoised; the arrays are shared: do not modify them."""
    import scipy.signal as ss

    key = (tuple(float(v) for v in num), tuple(float(v) for v in den), float(dt))
    got = _TF_MEMO.get(key)
    if got is None:
        b, a = _tf_coefficients_uncached(list(key[0]), list(key[1]), key[2])
        got = (b, a, ss.lfilter_zi(b, a))
        for arr in got:
            arr.setflags(write=False)
        if len(_TF_MEMO) >= 4096:
            _TF_MEMO.pop(next(iter(_TF_MEMO)))
        _TF_MEMO[key] = got
    return got


def _tf_coefficients_uncached(
    num: list[float], den: list[float], dt: float
) -> tuple[Float1D, Float1D]:
    import scipy.signal as ss

    b, a, _ = ss.cont2discrete((num, den), dt, method="foh")
    b = np.atleast_1d(np.squeeze(b)).astype(np.float64)
    a = np.atleast_1d(np.squeeze(a)).astype(np.float64)
    if b.size < a.size:
        b = np.concatenate((b, np.zeros(a.size - b.size)))
    return b / a[0], a / a[0]


def foh_filter(
    x: Float1D,
    num: list[float],
    den: list[float],
    dt: float,
    zi: Float1D | None = None,
    axis: int = 0,
) -> tuple[Float1D, Float1D]:
    """Filter ``x`` through the continuous transfer function ``num(s)/den(s)``.

    Parameters
    ----------
    x : ndarray of shape (N,) or (N, m) (or (m, N) with ``axis=-1``)
        Samples (columns are filtered independently).
    num, den : list of float
        Polynomial coefficients in ``s``, highest power first; ``num(0)/den(0) = 1`` for the
        effects of this module.
    dt : float
        Sample spacing in seconds.
    zi : ndarray, optional
        Direct-form-II-transposed state from a previous call; at rest at the first sample by
        default.
    axis : int
        Time axis of a 2-D ``x`` (0 or -1).

    Returns
    -------
    y : ndarray, same shape as ``x``
    zf : ndarray
        Final filter state (pass as ``zi`` to continue).
    """
    import scipy.signal as ss

    b, a, zi_unit = _tf_memo(num, den, dt)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 2 and axis in (-1, 1):
        if x.shape[1] == 0:
            return x.copy(), np.zeros((x.shape[0], a.size - 1)) if zi is None else zi
        if zi is None:
            zi = zi_unit[None, :] * x[:, :1]
        return ss.lfilter(b, a, x, axis=-1, zi=zi)
    if x.shape[0] == 0:
        return x.copy(), (np.zeros((a.size - 1,) + x.shape[1:]) if zi is None else zi)
    if zi is None:
        zi0 = zi_unit
        zi = zi0[:, None] * x[0][None, :] if x.ndim == 2 else zi0 * x[0]
    y, zf = ss.lfilter(b, a, x, axis=0, zi=zi)
    return y, zf


class _LinearStage(Model):
    """Shared machinery of the unit-DC-gain linear dynamics (state = filter state)."""

    needs_dt: ClassVar[bool] = True

    def _tf(self) -> tuple[list[float], list[float]]:  # pragma: no cover - abstract
        raise NotImplementedError

    def default_state(self) -> Any:
        return None  # at rest at the first input sample

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        num, den = self._tf()
        zi = None if state is None else np.asarray(state, dtype=np.float64)
        if zi is not None and zi.shape != (len(den) - 1,):
            raise ParameterError(
                f"{self.type_name} state must have {len(den) - 1} entries, got shape {zi.shape}"
            )
        y, zf = foh_filter(u, num, den, float(dt), zi)  # type: ignore[arg-type]
        return y, zf


@register_model
@dataclass(frozen=True, eq=False)
class Lag(_LinearStage):
    """First-order lag ``τ ẏ + y = x`` (amplifier output impedance × stack capacitance, sensor).

    Parameters
    ----------
    tau_s : float
        Time constant in seconds, ``tau_s > 0``.
    """

    type_name: ClassVar[str] = "lag"
    tau_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau_s", as_finite_scalar(self.tau_s, "tau_s", positive=True))

    def _tf(self) -> tuple[list[float], list[float]]:
        return [1.0], [self.tau_s, 1.0]

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type_name, "tau_s": self.tau_s}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Lag:
        _need(d, "tau_s", kind="lag")
        return cls(d["tau_s"])


@register_model
@dataclass(frozen=True, eq=False)
class Resonance(_LinearStage):
    """Second-order mode after the hysteresis, ``G(s) = ω_n² / (s² + 2ζω_n s + ω_n²)``.

    Parameters
    ----------
    freq_hz : float
        Natural frequency ``f_n = ω_n / 2π`` in hertz, ``> 0``.
    damping : float
        Damping ratio ``ζ > 0`` (dimensionless).
    """

    type_name: ClassVar[str] = "resonance"
    freq_hz: float
    damping: float

    def __post_init__(self) -> None:
        f = as_finite_scalar(self.freq_hz, "freq_hz", positive=True)
        z = as_finite_scalar(self.damping, "damping", positive=True)
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "damping", z)

    def _tf(self) -> tuple[list[float], list[float]]:
        w = 2.0 * np.pi * self.freq_hz
        return [w * w], [1.0, 2.0 * self.damping * w, w * w]

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type_name, "freq_hz": self.freq_hz, "damping": self.damping}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Resonance:
        _need(d, "freq_hz", "damping", kind="resonance")
        return cls(d["freq_hz"], d["damping"])


@register_model
@dataclass(frozen=True, eq=False)
class Delay(Model):
    """Pure transport delay ``y(t) = x(t - τ_d)`` (DAQ latency, ZOH, digital filters).

    Fractional delays interpolate linearly between samples. The state is the buffer of the
    last ``floor(τ_d/dt) + 1`` inputs (oldest first); by default the buffer holds the first
    input sample (the signal was at rest before the record).

    Parameters
    ----------
    delay_s : float
        Delay in seconds, ``delay_s >= 0``.
    """

    type_name: ClassVar[str] = "delay"
    needs_dt: ClassVar[bool] = True
    delay_s: float

    def __post_init__(self) -> None:
        d = as_finite_scalar(self.delay_s, "delay_s")
        if d < 0:
            raise ParameterError(
                f"delay_s = {d:g} must be >= 0 (a delay cannot predict the future)"
            )
        object.__setattr__(self, "delay_s", d)

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        D = self.delay_s / float(dt)  # type: ignore[arg-type]
        m = int(np.floor(D + 1e-12))
        f = max(D - m, 0.0)
        if state is None:
            hist = np.full(m + 1, u[0] if u.size else 0.0)
        else:
            hist = np.asarray(state, dtype=np.float64)
            if hist.shape != (m + 1,):
                raise ParameterError(
                    f"delay state must hold {m + 1} past samples for dt={dt:g} s, got "
                    f"shape {hist.shape}; continue with the same dt"
                )
        ext = np.concatenate((hist, u))
        k = np.arange(u.size)
        y = f * ext[k] + (1.0 - f) * ext[k + 1]
        return y, ext[-(m + 1) :].copy()

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type_name, "delay_s": self.delay_s}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Delay:
        _need(d, "delay_s", kind="delay")
        return cls(d["delay_s"])


@register_model
@dataclass(frozen=True, eq=False)
class Creep(Model):
    """Logarithmic creep as a bank of slow first-order lags (Krejčí–Kuhnen, linear form).

    ``y = x + Σ_j c_j (L_{τ_j}[x] - x)`` where ``τ_j L̇ + L = x``. After a step ``Δx`` the
    output keeps moving in the direction of the step; with equal ``c_j = γ`` on one lag per
    decade it moves by about ``γ Δx`` per decade of time (the PI tutorial's log law).

    Parameters
    ----------
    taus_s : array_like of shape (m,)
        Time constants in seconds, increasing, ``> 0``.
    weights : array_like of shape (m,)
        Creep weights ``c_j`` (dimensionless fraction of the step per lag), ``>= 0``.
    """

    type_name: ClassVar[str] = "creep"
    needs_dt: ClassVar[bool] = True
    taus_s: Float1D
    weights: Float1D

    def __post_init__(self) -> None:
        t = as_vector(self.taus_s, "taus_s", positive=True, increasing=True)
        w = as_vector(self.weights, "weights", length=t.size, nonnegative=True)
        object.__setattr__(self, "taus_s", t)
        object.__setattr__(self, "weights", w)

    @property
    def gamma_per_decade(self) -> float:
        """Mean creep weight per decade of time constant (≈ creep per decade of time)."""
        if self.taus_s.size < 2:
            return float(self.weights.sum())
        decades = np.log10(self.taus_s[-1] / self.taus_s[0]) + 1.0
        return float(self.weights.sum() / decades)

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        y = u.copy()
        out = []
        for j, (tau, c) in enumerate(zip(self.taus_s, self.weights, strict=True)):
            zi = None if state is None else np.asarray(state[j], dtype=np.float64)
            lj, zf = foh_filter(u, [1.0], [float(tau), 1.0], float(dt), zi)  # type: ignore[arg-type]
            y += c * (lj - u)
            out.append(zf)
        return y, tuple(out)

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type_name,
            "taus_s": self.taus_s.tolist(),
            "weights": self.weights.tolist(),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Creep:
        _need(d, "taus_s", "weights", kind="creep")
        return cls(d["taus_s"], d["weights"])


@register_model
@dataclass(frozen=True, eq=False)
class Drift(Model):
    """Slow additive drift in absolute time: ``y = x + Σ_k a_k P_k(2 t / T - 1)``.

    ``P_k`` are Legendre polynomials (k = 1..m) over the fitted span ``[0, T]``; outside that
    span the drift is held at its end value (polynomials must not be extrapolated). Time is
    counted from the first sample of the first ``simulate`` call; the state is the elapsed
    time in seconds.

    Parameters
    ----------
    coefficients : array_like of shape (m,)
        ``a_1..a_m`` in output units.
    span_s : float
        Length ``T`` of the time span in seconds, ``> 0``.
    """

    type_name: ClassVar[str] = "drift"
    needs_dt: ClassVar[bool] = True
    coefficients: Float1D
    span_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", as_vector(self.coefficients, "coefficients"))
        object.__setattr__(self, "span_s", as_finite_scalar(self.span_s, "span_s", positive=True))

    def drift(self, t: ArrayLike) -> Float1D:
        """Drift ``d(t)`` in output units at times ``t`` (seconds from the start), shape (N,)."""
        s = np.clip(2.0 * np.asarray(t, dtype=np.float64) / self.span_s - 1.0, -1.0, 1.0)
        return np.polynomial.legendre.legval(s, np.concatenate(([0.0], self.coefficients)))

    def default_state(self) -> float:
        return 0.0

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        t0 = float(state)
        t = t0 + np.arange(u.size) * float(dt)  # type: ignore[arg-type]
        return u + self.drift(t), t0 + u.size * float(dt)  # type: ignore[arg-type]

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type_name,
            "coefficients": self.coefficients.tolist(),
            "span_s": self.span_s,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Drift:
        _need(d, "coefficients", "span_s", kind="drift")
        return cls(d["coefficients"], d["span_s"])


@register_model
@dataclass(frozen=True, eq=False)
class Asymmetry(Model):
    """Static output map that bends the loop: ``y = x + Σ_k a_k ((x - c)/s)^k``, k = 2, 3, ...

    An even (k = 2) term makes the ascending and descending branches curve differently, a
    cubic term saturates or stiffens both ends (Gu et al. 2014 polynomial PI; Kuhnen's MPI
    output map to first order). Actuator asymmetry and sensor nonlinearity are both static
    output maps and cannot be told apart from (u, y) alone.

    Parameters
    ----------
    coefficients : array_like of shape (m,)
        ``a_2, a_3, ...`` in output units.
    center : float
        Centre ``c`` of the map (output units).
    scale : float
        Half-range ``s > 0`` of the map (output units).
    """

    type_name: ClassVar[str] = "asymmetry"
    coefficients: Float1D
    center: float
    scale: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", as_vector(self.coefficients, "coefficients"))
        object.__setattr__(self, "center", as_finite_scalar(self.center, "center"))
        object.__setattr__(self, "scale", as_finite_scalar(self.scale, "scale", positive=True))

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        q = (u - self.center) / self.scale
        y = u.copy()
        for k, a in enumerate(self.coefficients, start=2):
            y += a * q**k
        return y, None

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type_name,
            "coefficients": self.coefficients.tolist(),
            "center": self.center,
            "scale": self.scale,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Asymmetry:
        _need(d, "coefficients", "center", "scale", kind="asymmetry")
        return cls(d["coefficients"], d["center"], d["scale"])


@register_model
@dataclass(frozen=True, eq=False)
class Offset(Model):
    """Constant output (sensor) offset ``y = x + c``.

    Parameters
    ----------
    offset : float
        ``c`` in output units.
    """

    type_name: ClassVar[str] = "offset"
    offset: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset", as_finite_scalar(self.offset, "offset"))

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        return u + self.offset, None

    def inverse(self) -> Offset:
        return Offset(-self.offset)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type_name, "offset": self.offset}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Offset:
        _need(d, "offset", kind="offset")
        return cls(d["offset"])


# ----------------------------------------------------------------------------- rate-dependent PI
njit = kernels.njit


@njit(cache=True, nogil=True)
def _rd_play_matrix(u, r, k_rate, u_prev, z, out):  # pragma: no cover - compiled
    """Play outputs with thresholds ``r_i + k_rate * |u_k - u_{k-1}|`` (in place, see below)."""
    N = u.shape[0]
    n = r.shape[0]
    up = u_prev
    for k in range(N):
        uk = u[k]
        extra = k_rate * abs(uk - up)
        up = uk
        for i in range(n):
            ri = r[i] + extra
            zi = z[i]
            if zi > uk + ri:
                zi = uk + ri
            if zi < uk - ri:
                zi = uk - ri
            z[i] = zi
            out[k, i] = zi


def rd_play_bank(
    u: ArrayLike,
    thresholds: ArrayLike,
    beta_s: float,
    dt: float,
    state0: ArrayLike | None = None,
    u_prev: float | None = None,
) -> tuple[np.ndarray, Float1D]:
    """Play operators with additive rate-dependent thresholds ``r_i + β |u̇|``.

    The rate is the backward difference ``(u_k - u_{k-1}) / dt``. With ``β = 0`` this equals
    :func:`core.operators.play_bank`.

    Parameters
    ----------
    u : array_like of shape (N,)
    thresholds : array_like of shape (n,)
        Static thresholds ``r_i > 0`` (input units).
    beta_s : float
        Rate coefficient ``β`` in seconds (threshold increase per unit input rate).
    dt : float
        Sample spacing in seconds.
    state0 : array_like of shape (n,), optional
        Play outputs before the first sample (zeros by default).
    u_prev : float, optional
        Input before the first sample (``u[0]`` by default: no rate at the first sample).

    Returns
    -------
    Y : ndarray of shape (N, n)
    state : ndarray of shape (n,)
    """
    u = as_input_signal(u)
    r = np.ascontiguousarray(thresholds, dtype=np.float64)
    z = np.zeros(r.size) if state0 is None else np.array(state0, dtype=np.float64, copy=True)
    out = np.empty((u.size, r.size))
    if u.size:
        up = float(u[0]) if u_prev is None else float(u_prev)
        _rd_play_matrix(u, r, float(beta_s) / float(dt), up, z, out)
    return out, z


@register_model
@dataclass(frozen=True, eq=False)
class RateDependentPI(Model):
    """Rate-dependent PI: the r > 0 play thresholds widen with the input rate.

    ``y = p0 u + Σ p_i Γ_{r_i + β|u̇|}[u]`` (Al Janaideh, Su & Rakheja 2008, additive form,
    applied to the hysteretic operators only so that it differs from a pure delay: the
    reversible ``p0 u`` term is not delayed). The state is ``(play outputs, previous input)``.

    Parameters
    ----------
    p0 : float
        Weight of the reversible term (output units per input unit).
    thresholds : array_like of shape (n,)
        Static thresholds ``0 < r_1 < ... < r_n`` (input units).
    weights : array_like of shape (n,)
        Play weights.
    beta_s : float
        Rate coefficient β in seconds, ``>= 0``.
    state0 : array_like of shape (n,), optional
        Play outputs before the first sample (zeros by default).
    """

    type_name: ClassVar[str] = "rate"
    needs_dt: ClassVar[bool] = True
    p0: float
    thresholds: Float1D
    weights: Float1D
    beta_s: float
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        base = PIModel(self.p0, self.thresholds, self.weights, self.state0)
        object.__setattr__(self, "p0", base.p0)
        object.__setattr__(self, "thresholds", base.thresholds)
        object.__setattr__(self, "weights", base.weights)
        object.__setattr__(self, "state0", base.state0)
        b = as_finite_scalar(self.beta_s, "beta_s")
        if b < 0:
            raise ParameterError(
                f"beta_s = {b:g} must be >= 0 (thresholds cannot shrink with rate)"
            )
        object.__setattr__(self, "beta_s", b)

    @property
    def static(self) -> PIModel:
        """The rate-independent PI model (β = 0)."""
        return PIModel(self.p0, self.thresholds, self.weights, self.state0)

    def default_state(self) -> tuple[Float1D, None]:
        return (np.array(self.state0, copy=True), None)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        z, up = state
        Y, zf = rd_play_bank(u, self.thresholds, self.beta_s, float(dt), z, up)  # type: ignore[arg-type]
        y = self.p0 * u + Y @ self.weights
        return y, (zf, float(u[-1]) if u.size else up)

    def to_dict(self) -> dict[str, Any]:
        d = self.static.to_dict()
        d["type"] = self.type_name
        d["beta_s"] = self.beta_s
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RateDependentPI:
        _need(d, "p0", "thresholds", "weights", "beta_s", kind="rate")
        return cls(d["p0"], d["thresholds"], d["weights"], d["beta_s"], d.get("state0"))


# ----------------------------------------------------------------------------- initial memory
@register_model
@dataclass(frozen=True, eq=False)
class InitialMemory(Model):
    """A hysteresis model whose memory at the first sample comes from a virtual input history.

    The PI memory is the alternating sequence of dominant past input extrema, so an unknown
    initial state is parametrised by a few virtual extrema ``history`` applied (quasi-
    statically) before the record starts (missing-physics notes, E8).

    Parameters
    ----------
    model : PIModel or RateDependentPI
        The hysteresis model.
    history : array_like of shape (m,)
        Virtual input extrema (input units), applied in order before the first sample.
    """

    type_name: ClassVar[str] = "initial-memory"
    model: Model
    history: Float1D

    def __post_init__(self) -> None:
        if not isinstance(self.model, PIModel | RateDependentPI):
            raise ParameterError(
                "initial-memory wraps a 'pi' or 'rate' model (a bank of play operators), got "
                f"{type(self.model).__name__}"
            )
        object.__setattr__(self, "history", as_vector(self.history, "history"))

    @property
    def needs_dt(self) -> bool:  # type: ignore[override]
        return self.model.needs_dt

    @property
    def play_state(self) -> Float1D:
        """Play outputs after the virtual history, shape (n,)."""
        from .operators import play_bank

        m = self.model
        _, z = play_bank(self.history, m.thresholds, m.state0)  # type: ignore[attr-defined]
        return frozen(z)

    def with_state(self) -> Model:
        """The wrapped model with ``state0`` set to :attr:`play_state`."""
        m = self.model
        z = self.play_state
        if isinstance(m, RateDependentPI):
            return RateDependentPI(m.p0, m.thresholds, m.weights, m.beta_s, z)
        return PIModel(m.p0, m.thresholds, m.weights, z)  # type: ignore[attr-defined]

    def default_state(self) -> Any:
        return self.with_state().default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        return self.with_state()._run(u, state, dt)

    def inverse(self) -> Model:
        inner = self.with_state()
        if isinstance(inner, PIModel):
            return inner.inverse()
        raise NotInvertibleError("a rate-dependent PI model has no analytical inverse here")

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type_name,
            "history": self.history.tolist(),
            "model": self.model.to_dict(),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> InitialMemory:
        _need(d, "history", "model", kind="initial-memory")
        return cls(model_from_dict(d["model"]), d["history"])
