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

Every effect inverts (``inverse()``), exactly where the physics allows:

============== ========================== ========================================================
effect         inverse                    how, and what is exact
============== ========================== ========================================================
offset, drift  the same, negated          exact (drift as a function of time)
lag            :class:`LagInverse`        exact inverse of the discretised lag (per-sample solve)
creep          :class:`CreepInverse`      exact inverse of the minimum-phase discrete operator
resonance      :class:`ResonanceInverse`  mode cancelled, 3rd-order roll-off at ``bandwidth_hz``;
                                          error ``<= 3 max|ÿ| / (2π f_c)²``
asymmetry      :class:`AsymmetryInverse`  bisection on the monotone range, clipped (warning) outside
rate           :class:`RateDependentPIInverse` per-sample bisection, tolerance ≈ 1e-15 relative
initial-memory inverse PI / rate inverse  started in the consistent state
delay          :class:`Advance`           non-causal: needs ``preview_samples(dt)`` samples ahead;
                                          :func:`causal_form` gives the real-time compensator
============== ========================== ========================================================
"""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D
from .base import SAMPLE_BYTES, Chain, Control, Field, Model, RunCost, register_model
from .exceptions import ClippedInputWarning, NotInvertibleError, ParameterError
from .pi import PIModel
from .preisach import PreisachModel, RateDependentPreisach, checked_rate_slopes
from .validation import as_finite_scalar, as_input_signal, as_vector, frozen

__all__ = [
    "Advance",
    "Asymmetry",
    "AsymmetryInverse",
    "CausalForm",
    "Creep",
    "CreepInverse",
    "Delay",
    "Drift",
    "InitialMemory",
    "Lag",
    "LagBank",
    "LagInverse",
    "Offset",
    "RateDependentPI",
    "RateDependentPIInverse",
    "Resonance",
    "ResonanceInverse",
    "bisect_steps",
    "causal_form",
    "delay_split",
    "discretised_tf",
    "foh_filter",
    "rd_play_bank",
]


njit = kernels.njit


# ----------------------------------------------------------------------------- linear filters
def _tf_coefficients(num: list[float], den: list[float], dt: float) -> tuple[Float1D, Float1D]:
    """First-order-hold discretisation of ``num(s)/den(s)`` (exact for piecewise-linear input).

    Memoised on the exact float values (the diagnosis filters thousands of regressor
    columns with a few distinct transfer functions); copies are returned.
    """
    b, a, _ = discretised_tf(num, den, dt)
    return b.copy(), a.copy()


def discretised_tf(num: list[float], den: list[float], dt: float
                   ) -> tuple[Float1D, Float1D, Float1D]:
    """``(b, a, lfilter_zi(b, a))``, memoised; the arrays are shared: do not modify them.

    Thread-safe: the cache is :func:`functools.lru_cache` on the exact float values (the
    explorer serves concurrent requests from worker threads).
    """
    return _tf_memo_key(tuple(float(v) for v in num), tuple(float(v) for v in den), float(dt))


@functools.lru_cache(maxsize=4096)
def _tf_memo_key(
    num: tuple[float, ...], den: tuple[float, ...], dt: float
) -> tuple[Float1D, Float1D, Float1D]:
    import scipy.signal as ss

    b, a = _tf_coefficients_uncached(list(num), list(den), dt)
    got = (b, a, ss.lfilter_zi(b, a))
    for arr in got:
        arr.setflags(write=False)
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

    b, a, zi_unit = discretised_tf(num, den, dt)
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

    def discrete(self, dt: float) -> tuple[Float1D, Float1D]:
        """``(b, a)``: the first-order-hold discretisation at ``dt`` (``a[0] = 1``)."""
        num, den = self._tf()
        return _tf_coefficients(num, den, float(dt))

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


# ----------------------------------------------------------------------------- lag banks
@njit(cache=True, nogil=True)
def _lag_bank_forward(x, g0, c, b0, b1, a1, s, out):  # pragma: no cover - compiled
    """``y = g0 x + Σ c_j L_j[x]``, each ``L_j`` a first-order DF2T section (state ``s``)."""
    m = c.shape[0]
    for k in range(x.shape[0]):
        xk = x[k]
        acc = g0 * xk
        for j in range(m):
            lj = b0[j] * xk + s[j]
            s[j] = b1[j] * xk - a1[j] * lj
            acc += c[j] * lj
        out[k] = acc


@njit(cache=True, nogil=True)
def _lag_bank_inverse(y, g0, c, b0, b1, a1, s, out):  # pragma: no cover - compiled
    """Exact per-sample inverse of :func:`_lag_bank_forward` (same state layout)."""
    m = c.shape[0]
    gain = g0
    for j in range(m):
        gain += c[j] * b0[j]
    for k in range(y.shape[0]):
        acc = y[k]
        for j in range(m):
            acc -= c[j] * s[j]
        xk = acc / gain
        for j in range(m):
            lj = b0[j] * xk + s[j]
            s[j] = b1[j] * xk - a1[j] * lj
        out[k] = xk


@dataclass(frozen=True)
class LagBank:
    """A bank ``y = g0 x + Σ_j c_j L_j[x]`` of first-order lags discretised at ``dt``.

    The common form of :class:`Lag` (``g0 = 0``, one lag of weight 1) and :class:`Creep`
    (``g0 = 1 - Σ c_j``); the C export and the inverses use it.

    Attributes
    ----------
    g0 : float
        Direct weight.
    c, b0, b1, a1 : ndarray of shape (m,)
        Lag weights and the DF2T coefficients of each section
        (``L = b0 x + s``, ``s ← b1 x - a1 L``).
    zi : ndarray of shape (m,)
        Section states at rest for a unit input (multiply by the first sample).
    """

    g0: float
    c: Float1D
    b0: Float1D
    b1: Float1D
    a1: Float1D
    zi: Float1D

    @classmethod
    def of(cls, taus_s: ArrayLike, weights: ArrayLike, g0: float, dt: float) -> LagBank:
        """Discretise lags ``taus_s`` (s) with weights at ``dt`` (s)."""
        b0, b1, a1, zi = [], [], [], []
        for tau in np.asarray(taus_s, dtype=np.float64):
            b, a, z = discretised_tf([1.0], [float(tau), 1.0], float(dt))
            b0.append(b[0])
            b1.append(b[1])
            a1.append(a[1])
            zi.append(z[0])
        return cls(float(g0), np.asarray(weights, dtype=np.float64), np.array(b0),
                   np.array(b1), np.array(a1), np.array(zi))

    @property
    def gain0(self) -> float:
        """Instantaneous gain ``g0 + Σ c_j b0_j`` (the inverse divides by it)."""
        return float(self.g0 + self.c @ self.b0)

    def gain_at_nyquist(self) -> float:
        """Frequency response at ``z = -1`` (real): > 0 with ``gain0 > 0`` means every zero
        lies in (-1, 1), i.e. the discrete operator is minimum phase (the weights
        ``c_j (1 - p_j)²/α_j`` of its partial fractions are positive, so zeros interlace the
        poles and only the leftmost one can leave the unit disc)."""
        # section transfer (b0 z + b1)/(z + a1) at z = -1
        return float(self.g0 + self.c @ ((self.b1 - self.b0) / (self.a1 - 1.0)))

    def states(self, state: Any, x0: float) -> Float1D:
        """Section states from a stage state (``None``: at rest at ``x0``)."""
        if state is None:
            return self.zi * x0
        s = np.asarray(state, dtype=np.float64).ravel()
        if s.shape != self.c.shape:
            raise ParameterError(
                f"lag-bank state must hold {self.c.size} section state(s), got {s.size}"
            )
        return s.copy()


def _lag_state_tuple(s: Float1D) -> tuple[Float1D, ...]:
    return tuple(np.array([v]) for v in s)


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
    fields: ClassVar[tuple[Field, ...]] = (
        Field("tau_s", "number", doc="time constant (s)", title="Time constant τ",
              control=Control("τ", "s", (0.001, 2.0), lower=0.0, strict=True, scale=1e-3,
                              log=True)),
    )
    tau_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau_s", as_finite_scalar(self.tau_s, "tau_s", positive=True))

    def _tf(self) -> tuple[list[float], list[float]]:
        return [1.0], [self.tau_s, 1.0]

    def bank(self, dt: float) -> LagBank:
        """This lag as a :class:`LagBank` at ``dt``."""
        return LagBank.of([self.tau_s], [1.0], 0.0, dt)

    def time_constants(self) -> tuple[tuple[str, float], ...]:
        """The lag's time constant (s)."""
        return (("lag tau_s", float(self.tau_s)),)

    def inverse(self) -> LagInverse:
        """The exact inverse of the discretised lag (its FOH zero lies in (-1, 0))."""
        return LagInverse(self.tau_s)


@register_model
@dataclass(frozen=True, eq=False)
class LagInverse(Model):
    """Exact inverse of the first-order-hold discretised :class:`Lag` (per-sample solve).

    ``x_k = (y_k - s_k) / b0`` with the lag's own DF2T state ``s``, so
    ``Lag(τ)(LagInverse(τ)(y)) == y`` to rounding from the first sample. The state is the
    forward lag's filter state (shape (1,)); by default at rest at the first sample. The
    inverse amplifies the input's high frequencies by up to ``|H(-1)|⁻¹`` (≈ 2τ/dt·... for
    τ ≫ dt): feed it a smooth desired trajectory.

    Parameters
    ----------
    tau_s : float
        Time constant of the lag being inverted (s).
    """

    type_name: ClassVar[str] = "lag-inverse"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        Field("tau_s", "number", doc="time constant of the inverted lag (s)",
              title="Time constant τ",
              control=Control("τ", "s", (0.001, 2.0), lower=0.0, strict=True, scale=1e-3,
                              log=True)),
    )
    tau_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "tau_s", as_finite_scalar(self.tau_s, "tau_s", positive=True))

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        bank = Lag(self.tau_s).bank(float(dt))  # type: ignore[arg-type]
        s = bank.states(state, float(u[0]) if u.size else 0.0)
        out = np.empty_like(u)
        _lag_bank_inverse(u, bank.g0, bank.c, bank.b0, bank.b1, bank.a1, s, out)
        return out, s

    def inverse(self) -> Lag:
        return Lag(self.tau_s)


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
    fields: ClassVar[tuple[Field, ...]] = (
        Field("freq_hz", "number", doc="natural frequency (Hz)", title="Natural frequency f_n",
              control=Control("f_n", "Hz", (0.01, 2.0), lower=0.0, strict=True, scale=100.0,
                              log=True)),
        Field("damping", "number", doc="damping ratio", title="Damping ratio ζ",
              control=Control("ζ", "1", (0.0, 1.5), step=0.001, relative=False, lower=0.0,
                              strict=True)),
    )
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

    def time_constants(self) -> tuple[tuple[str, float], ...]:
        """The mode's ``1 / (2 pi f_n)`` (s)."""
        return (("resonance 1/(2 pi freq_hz)", 1.0 / (2 * math.pi * float(self.freq_hz))),)

    def inverse(self, bandwidth_hz: float | None = None) -> ResonanceInverse:
        """Inverse with a third-order roll-off at ``bandwidth_hz`` (default ``4 f_n``).

        The discretised mode has a sampling zero outside the unit disc (relative degree 2),
        so no stable exact inverse exists; see :class:`ResonanceInverse` for the error bound.
        """
        return ResonanceInverse(
            self.freq_hz, self.damping,
            4.0 * self.freq_hz if bandwidth_hz is None else bandwidth_hz,
        )


@register_model
@dataclass(frozen=True, eq=False)
class ResonanceInverse(_LinearStage):
    """Inverse of a :class:`Resonance` with a documented roll-off.

    ``F(s) = G(s)⁻¹ L(s)`` with ``G`` the mode and the roll-off
    ``L(s) = (1 + 3s/ω_c) / (1 + s/ω_c)³`` (``ω_c = 2π f_c``), so ``G F = L``: the mode is
    cancelled and what is left is ``L``, whose error ``1 - L`` is of second order (no lag to
    first order). Error bound (continuous time): for any desired trajectory ``y_d`` with
    bounded curvature, ``|G F y_d - y_d| ≤ 3 max|ÿ_d| / ω_c²`` (``(1 - L)/s²`` has a positive
    impulse response of area ``3/ω_c²``); a sinusoid of frequency ``f`` comes back with a
    relative error ``≤ 3 (f/f_c)²``, against ``≈ (f/f_n)²`` without compensation. Sampling
    (FOH at ``dt``) adds an error of order ``(f_c dt)²`` (within 5 % of the bound for
    ``f_c dt ≤ 0.025``, about 60 % of it at ``f_c dt = 0.1``; tested). The
    high-frequency gain of ``F`` is ``3 (f_c/f_n)²``: a larger ``f_c`` tracks better and
    amplifies noise more.

    Parameters
    ----------
    freq_hz, damping : float
        The mode being inverted (Hz, dimensionless).
    bandwidth_hz : float
        Roll-off frequency ``f_c > 0`` in hertz.
    """

    type_name: ClassVar[str] = "resonance-inverse"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("freq_hz", "number", doc="natural frequency of the inverted mode (Hz)",
              title="Natural frequency f_n", scale_with=("bandwidth_hz",),
              control=Control("f_n", "Hz", (0.01, 1.5), lower=0.0, strict=True, scale=100.0,
                              log=True)),
        Field("damping", "number", doc="damping ratio of the inverted mode",
              title="Damping ratio ζ",
              control=Control("ζ", "1", (0.0, 1.5), step=0.001, relative=False, lower=0.0,
                              strict=True)),
        Field("bandwidth_hz", "number", doc="roll-off (triple pole) frequency (Hz)",
              title="Roll-off frequency", scale_with=("freq_hz",),
              control=Control("f_roll", "Hz", (0.01, 1.5), lower=0.0, strict=True,
                              scale=100.0, log=True)),
    )
    freq_hz: float
    damping: float
    bandwidth_hz: float

    def __post_init__(self) -> None:
        Resonance(self.freq_hz, self.damping)  # same rules
        object.__setattr__(self, "freq_hz", float(self.freq_hz))
        object.__setattr__(self, "damping", float(self.damping))
        object.__setattr__(
            self, "bandwidth_hz", as_finite_scalar(self.bandwidth_hz, "bandwidth_hz", positive=True)
        )

    def _tf(self) -> tuple[list[float], list[float]]:
        w = 2.0 * np.pi * self.freq_hz
        wc = 2.0 * np.pi * self.bandwidth_hz
        num = (wc * wc / (w * w)) * np.polymul([1.0, 2.0 * self.damping * w, w * w], [3.0, wc])
        return num.tolist(), [1.0, 3.0 * wc, 3.0 * wc * wc, wc**3]

    def rolloff(self) -> tuple[list[float], list[float]]:
        """``(num, den)`` of what remains after the mode, ``L(s)`` (highest power first)."""
        wc = 2.0 * np.pi * self.bandwidth_hz
        return [3.0 * wc * wc, wc**3], [1.0, 3.0 * wc, 3.0 * wc * wc, wc**3]

    def error_bound(self, max_curvature: float) -> float:
        """Bound on ``|G F y_d - y_d|`` for a trajectory with ``|ÿ_d| ≤ max_curvature``."""
        wc = 2.0 * np.pi * self.bandwidth_hz
        return 3.0 * abs(float(max_curvature)) / (wc * wc)

    def inverse(self) -> Resonance:
        """The mode itself (the roll-off is dropped: this is not an exact inverse)."""
        return Resonance(self.freq_hz, self.damping)


# ----------------------------------------------------------------------------- delay
def delay_split(delay_s: float, dt: float) -> tuple[int, float]:
    """``(m, f)``: the delay in samples ``m + f`` with ``0 <= f < 1``."""
    D = delay_s / dt
    m = int(np.floor(D + 1e-12))
    return m, max(D - m, 0.0)


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
    fields: ClassVar[tuple[Field, ...]] = (
        Field("delay_s", "number", doc="delay (s)", title="Delay τ_d",
              control=Control("τ_d", "s", (0.0, 2.0), lower=0.0, scale=1e-3)),
    )
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
        m, f = delay_split(self.delay_s, float(dt))  # type: ignore[arg-type]
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

    def inverse(self) -> Advance:
        """The advance ``x(t + τ_d)``: no causal inverse exists, so the inverse needs a
        preview of ``ceil(τ_d/dt)`` samples of the desired trajectory (:class:`Advance`)."""
        return Advance(self.delay_s)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """One pass over the input plus a buffer of ``delay_s / dt`` samples (work in
        element operations, memory in bytes)."""
        m = self.delay_s / dt if dt and dt > 0 else 0.0
        n = float(samples) + m + 1.0
        return RunCost(4.0 * n, 6.0 * SAMPLE_BYTES * n)


@register_model
@dataclass(frozen=True, eq=False)
class Advance(Model):
    """The inverse of a :class:`Delay`: ``y(t) = x(t + τ_d)``, which needs the future.

    ``simulate`` treats its input as the whole known trajectory: ``y_k = (1-f) x_{k+m} +
    f x_{k+m+1}`` (``τ_d/dt = m + f``), the last sample held beyond the end. It therefore is
    not chunkable; a real-time compensator is its causal form (:func:`causal_form`): fed the
    desired trajectory :meth:`preview_samples` samples ahead, the advance becomes a causal
    delay of ``preview - τ_d/dt`` samples. ``Delay(Advance(x)) == x`` exactly for a delay
    that is a whole number of samples; for a fractional one the round trip is ``x``
    smoothed by the kernel ``[f(1-f), 1 - 2f(1-f), f(1-f)]``, an error of at most
    ``f(1-f) max|x_{k+1} - 2x_k + x_{k-1}|``. The last ``preview`` samples of a finite
    record lack their future and are held.

    Parameters
    ----------
    delay_s : float
        The delay being inverted (s), ``>= 0``.
    """

    type_name: ClassVar[str] = "advance"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        Field("delay_s", "number", doc="delay being compensated (s)", title="Delay τ_d",
              control=Control("τ_d", "s", (0.0, 2.0), lower=0.0, scale=1e-3)),
    )
    delay_s: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "delay_s", Delay(self.delay_s).delay_s)

    def preview_samples(self, dt: float | None) -> int:
        if dt is None or not dt > 0:
            raise ParameterError("the inverse of a delay needs the sample spacing dt > 0 (s)")
        m, f = delay_split(self.delay_s, float(dt))
        return m + (1 if f > 0 else 0)

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        m, f = delay_split(self.delay_s, float(dt))  # type: ignore[arg-type]
        if not u.size:
            return u.copy(), None
        ext = np.concatenate((u, np.full(m + 1, u[-1])))
        k = np.arange(u.size)
        return (1.0 - f) * ext[k + m] + f * ext[k + m + 1], None

    def causal(self, dt: float) -> Delay:
        """The causal delay this stage becomes when its input is previewed."""
        m, f = delay_split(self.delay_s, float(dt))
        return Delay((self.preview_samples(dt) - (m + f)) * float(dt))

    def inverse(self) -> Delay:
        return Delay(self.delay_s)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """One pass over the input plus a buffer of ``delay_s / dt`` samples (work in
        element operations, memory in bytes)."""
        m = self.delay_s / dt if dt and dt > 0 else 0.0
        n = float(samples) + m + 1.0
        return RunCost(4.0 * n, 6.0 * SAMPLE_BYTES * n)


# ----------------------------------------------------------------------------- creep
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
    fields: ClassVar[tuple[Field, ...]] = (
        Field("taus_s", "numbers", doc="lag time constants (s), increasing",
              title="Creep time constants τ_j", increasing=True,
              control=Control("τ{i}", "s", (0.001, 1.25), lower=0.0, strict=True, log=True)),
        Field("weights", "numbers", doc="creep weight of each lag (fraction of a step)",
              title="Creep weights c_j",
              control=Control("c{i}", "1", (0.0, 2.0), lower=0.0, scale=0.01)),
    )
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

    def time_constants(self) -> tuple[tuple[str, float], ...]:
        """Each lag's time constant (s)."""
        return tuple(("creep taus_s", float(t)) for t in self.taus_s)

    def bank(self, dt: float) -> LagBank:
        """This operator as a :class:`LagBank` at ``dt`` (``g0 = 1 - Σ c_j``)."""
        return LagBank.of(self.taus_s, self.weights, 1.0 - float(self.weights.sum()), dt)

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

    def inverse(self) -> CreepInverse:
        """Inverse of the minimum-phase discrete operator (per-sample, exact).

        Raises
        ------
        NotInvertibleError
            If ``Σ c_j >= 1``: the creep then has no instantaneous response left (or a
            right-half-plane zero) and its inverse would be improper or unstable.
        """
        total = float(self.weights.sum())
        if total >= 1.0:
            raise NotInvertibleError(
                f"creep weights sum to {total:g} >= 1: the operator's high-frequency gain "
                "1 - sum(weights) is not positive, so it has no stable causal inverse"
            )
        return CreepInverse(self.taus_s, self.weights)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Terms x samples: one filtered pass of the input per lag (element operations,
        bytes)."""
        n, m = float(samples), float(self.taus_s.size)
        return RunCost(12.0 * n * m, SAMPLE_BYTES * (5.0 * n + m))


@register_model
@dataclass(frozen=True, eq=False)
class CreepInverse(Model):
    """Exact inverse of the discretised :class:`Creep` operator.

    The creep is a bank of lags ``y = g0 x + Σ c_j L_j[x]`` (:class:`LagBank`), solved for
    ``x`` at every sample: ``x_k = (y_k - Σ c_j s_j) / (g0 + Σ c_j b0_j)``. With ``c_j >= 0``
    and ``Σ c_j < 1`` the discrete operator is minimum phase whenever its response at
    Nyquist is positive (checked at run time: ``ParameterError`` otherwise), so the inverse
    is stable; ``Creep(CreepInverse(y)) == y`` to rounding. The state is the creep's own
    state (one filter state per lag); by default at rest at the first sample.

    Parameters
    ----------
    taus_s, weights : array_like of shape (m,)
        The creep being inverted (see :class:`Creep`).
    """

    type_name: ClassVar[str] = "creep-inverse"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = Creep.fields
    taus_s: Float1D
    weights: Float1D

    def __post_init__(self) -> None:
        fwd = Creep(self.taus_s, self.weights)
        object.__setattr__(self, "taus_s", fwd.taus_s)
        object.__setattr__(self, "weights", fwd.weights)

    def checked_bank(self, dt: float) -> LagBank:
        """The forward :class:`LagBank` at ``dt``, checked to be minimum phase."""
        bank = Creep(self.taus_s, self.weights).bank(dt)
        if not (bank.gain0 > 0 and bank.gain_at_nyquist() > 0):
            raise ParameterError(
                f"creep inverse at dt={dt:g} s is unstable (the discretised creep is not "
                "minimum phase); sample faster or reduce the creep weights"
            )
        return bank

    def default_state(self) -> Any:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        bank = self.checked_bank(float(dt))  # type: ignore[arg-type]
        s = bank.states(None if state is None else [np.ravel(v)[0] for v in state],
                        float(u[0]) if u.size else 0.0)
        out = np.empty_like(u)
        _lag_bank_inverse(u, bank.g0, bank.c, bank.b0, bank.b1, bank.a1, s, out)
        return out, _lag_state_tuple(s)

    def inverse(self) -> Creep:
        return Creep(self.taus_s, self.weights)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Terms x samples: every lag updated at every sample (element operations, bytes)."""
        n, m = float(samples), float(self.taus_s.size)
        return RunCost(4.0 * n * (m + 1.0), SAMPLE_BYTES * (2.0 * n + 4.0 * m))


# ----------------------------------------------------------------------------- drift
@register_model
@dataclass(frozen=True, eq=False)
class Drift(Model):
    """Slow additive drift in absolute time: ``y = x + Σ_k a_k P_k(2 t / T - 1)``.

    ``P_k`` are Legendre polynomials (k = 1..m) over the fitted span ``[0, T]``; outside that
    span the drift is held at its end value (polynomials must not be extrapolated). Time is
    counted from the first sample of the first ``simulate`` call (``start_s`` at that
    sample); the state is the elapsed time in seconds. The inverse is the drift with the
    opposite sign (exact).

    Parameters
    ----------
    coefficients : array_like of shape (m,)
        ``a_1..a_m`` in output units.
    span_s : float
        Length ``T`` of the time span in seconds, ``> 0``.
    start_s : float
        Time of the first sample (s), 0 by default (a previewed compensator starts early).
    """

    type_name: ClassVar[str] = "drift"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        Field("coefficients", "numbers", doc="Legendre coefficients a_1..a_m (output units)",
              title="Drift coefficients a_k", control=Control("a{i}", "output", (-2.0, 2.0))),
        Field("span_s", "number", doc="time span of the drift (s)", title="Drift span T",
              control=Control("T", "s", (0.0, 2.0), lower=0.0, strict=True)),
        Field("start_s", "number", optional=True, default=0.0, title="Start time t0",
              scale_with=("span_s",), control=Control("t0", "s", (-1.0, 1.0)),
              doc="time of the first sample (s)"),
    )
    coefficients: Float1D
    span_s: float
    start_s: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", as_vector(self.coefficients, "coefficients"))
        object.__setattr__(self, "span_s", as_finite_scalar(self.span_s, "span_s", positive=True))
        object.__setattr__(self, "start_s", as_finite_scalar(self.start_s, "start_s"))

    def drift(self, t: ArrayLike) -> Float1D:
        """Drift ``d(t)`` in output units at times ``t`` (seconds from the start), shape (N,)."""
        s = np.clip(2.0 * np.asarray(t, dtype=np.float64) / self.span_s - 1.0, -1.0, 1.0)
        return np.polynomial.legendre.legval(s, np.concatenate(([0.0], self.coefficients)))

    def default_state(self) -> float:
        return self.start_s

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        t0 = float(state)
        t = t0 + np.arange(u.size) * float(dt)  # type: ignore[arg-type]
        return u + self.drift(t), t0 + u.size * float(dt)  # type: ignore[arg-type]

    def inverse(self) -> Drift:
        return Drift(-self.coefficients, self.span_s, self.start_s)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Coefficients x samples: one Legendre recurrence step per coefficient and sample
        (element operations, bytes)."""
        n, m = float(samples), float(self.coefficients.size)
        return RunCost(6.0 * n * (m + 2.0), SAMPLE_BYTES * (7.0 * n + m))


# ----------------------------------------------------------------------------- output maps
def bisect_steps() -> int:
    """Bisection steps of the memoryless inverse maps (bracket width × 2⁻⁸⁰ ≈ 1e-24)."""
    return 80


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
    fields: ClassVar[tuple[Field, ...]] = (
        Field("coefficients", "numbers", doc="a_2, a_3, ... (output units)",
              title="Bend coefficients a_k", index_base=2, scale_with=("scale",),
              control=Control("a{i}", "output", (-0.25, 0.25))),
        Field("center", "number", doc="centre of the map (output units)", title="Centre c",
              scale_with=("scale",), control=Control("c", "output", (-1.0, 1.0))),
        Field("scale", "number", doc="half-range of the map (output units)",
              title="Half-range s",
              control=Control("s", "output", (0.0, 2.0), lower=0.0, strict=True)),
    )
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

    def monotone_range(self) -> tuple[float, float]:
        """``(x_lo, x_hi)``: the interval around ``center`` where the map increases (input
        units, ``±inf`` when unbounded). The inverse maps onto it."""
        # dy/dq = s + Σ k a_k q^(k-1), q = (x - c)/s; polynomial highest power first
        a = self.coefficients
        poly = [k * a[k - 2] for k in range(a.size + 1, 1, -1)] + [self.scale]
        poly = np.trim_zeros(np.asarray(poly, dtype=np.float64), "f")
        roots = np.roots(poly) if poly.size > 1 else np.array([])
        real = roots[np.abs(roots.imag) <= 1e-12 * np.maximum(1.0, np.abs(roots))].real
        lo = real[real < 0].max() if np.any(real < 0) else -np.inf
        hi = real[real > 0].min() if np.any(real > 0) else np.inf
        return self.center + self.scale * lo, self.center + self.scale * hi

    def inverse(self) -> AsymmetryInverse:
        return AsymmetryInverse(self.coefficients, self.center, self.scale)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Coefficients x samples: one power per coefficient and sample (element
        operations, bytes)."""
        n, m = float(samples), float(self.coefficients.size)
        return RunCost(40.0 * n * (m + 1.0), SAMPLE_BYTES * (5.0 * n + m))


def _poly_map(x: np.ndarray, coef: Float1D, c: float, s: float) -> np.ndarray:
    """The asymmetry map in Horner form (the order the C export uses)."""
    q = (x - c) / s
    acc = np.zeros_like(q)
    for a in coef[::-1]:
        acc = (acc + a) * q
    return x + acc * q


@register_model
@dataclass(frozen=True, eq=False)
class AsymmetryInverse(Model):
    """Inverse of an :class:`Asymmetry` output map, by bisection on its monotone range.

    Inputs outside the image of :meth:`Asymmetry.monotone_range` are clipped to it with a
    :class:`~core.exceptions.ClippedInputWarning`. Each sample is bracketed (expanding by
    doubling on an unbounded side, at most 64 times) and bisected 80 times, so the result is
    within ``2⁻⁸⁰`` of the bracket width of the exact pre-image (tolerance ≈ 1e-15 relative;
    the C export runs the same steps). ``Asymmetry(AsymmetryInverse(y)) == y`` to rounding on
    the range.

    Parameters
    ----------
    coefficients, center, scale
        The map being inverted (see :class:`Asymmetry`).
    """

    type_name: ClassVar[str] = "asymmetry-inverse"
    fields: ClassVar[tuple[Field, ...]] = Asymmetry.fields
    coefficients: Float1D
    center: float
    scale: float

    def __post_init__(self) -> None:
        fwd = Asymmetry(self.coefficients, self.center, self.scale)
        for k in ("coefficients", "center", "scale"):
            object.__setattr__(self, k, getattr(fwd, k))

    @property
    def forward(self) -> Asymmetry:
        """The map being inverted."""
        return Asymmetry(self.coefficients, self.center, self.scale)

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        coef, c, s = self.coefficients, self.center, self.scale
        x_lo, x_hi = self.forward.monotone_range()
        y = u.copy()
        below = np.zeros(u.shape, dtype=bool)
        above = np.zeros(u.shape, dtype=bool)
        if np.isfinite(x_lo):
            y_lo = _poly_map(np.array([x_lo]), coef, c, s)[0]
            below = y < y_lo
            y[below] = y_lo
        if np.isfinite(x_hi):
            y_hi = _poly_map(np.array([x_hi]), coef, c, s)[0]
            above = y > y_hi
            y[above] = y_hi
        clipped = int(np.count_nonzero(below | above))
        if clipped:
            warnings.warn(
                f"{clipped} sample(s) outside the range of the asymmetry map were clipped "
                f"to it (input range [{x_lo:.6g}, {x_hi:.6g}])",
                ClippedInputWarning, stacklevel=4,
            )
        lo = np.full_like(y, x_lo if np.isfinite(x_lo) else c - s)
        hi = np.full_like(y, x_hi if np.isfinite(x_hi) else c + s)
        for _ in range(64):
            if not np.isfinite(x_lo):
                grow = _poly_map(lo, coef, c, s) > y
                lo = np.where(grow, c - 2.0 * (c - lo), lo)
            if not np.isfinite(x_hi):
                grow = _poly_map(hi, coef, c, s) < y
                hi = np.where(grow, c + 2.0 * (hi - c), hi)
        for _ in range(bisect_steps()):
            mid = 0.5 * (lo + hi)
            less = _poly_map(mid, coef, c, s) < y
            lo = np.where(less, mid, lo)
            hi = np.where(less, hi, mid)
        x = 0.5 * (lo + hi)
        x[below] = x_lo
        x[above] = x_hi
        return x, None

    def inverse(self) -> Asymmetry:
        return self.forward

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Coefficients x samples x bisection steps (bracket expansion on both sides and
        :func:`bisect_steps`), plus the roots of the map's derivative (a dense eigenvalue
        problem of the coefficients' size), plus about a microsecond (1,000 units) for each
        of the four array passes of every step whatever the length: that is most of a call
        on one sample (a closed loop calls the inverse once per sample: 3-13 ms each,
        measured). Work in element operations, memory in bytes."""
        n, m = float(samples), float(self.coefficients.size)
        steps = 2.0 * 64.0 + bisect_steps()
        work = 3.0 * n * (m + 2.0) * steps + 10.0 * m**3 + 4.0 * 1000.0 * steps
        memory = SAMPLE_BYTES * (9.0 * n + 4.0 * m * m)
        return RunCost(work, memory)


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
    fields: ClassVar[tuple[Field, ...]] = (
        Field("offset", "number", doc="offset (output units)", title="Offset c",
              control=Control("c", "output", (-2.0, 2.0))),
    )
    offset: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset", as_finite_scalar(self.offset, "offset"))

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        return u + self.offset, None

    def inverse(self) -> Offset:
        return Offset(-self.offset)


# ----------------------------------------------------------------------------- rate-dependent PI


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

@njit(cache=True, nogil=True)
def _rd_eval(u, r, w, p0, k_rate, up, has_prev, z):  # pragma: no cover - compiled
    """Output of the rate-dependent PI for the sample ``u`` from plays ``z`` (not updated)."""
    extra = k_rate * abs(u - up) if has_prev else 0.0
    acc = p0 * u
    for i in range(r.shape[0]):
        ri = r[i] + extra
        zi = z[i]
        if zi > u + ri:
            zi = u + ri
        if zi < u - ri:
            zi = u - ri
        acc += w[i] * zi
    return acc


@njit(cache=True, nogil=True)
def _rd_inverse(y, r, w, p0, k_rate, m_lo, m_hi, up, has_prev, z, out):  # pragma: no cover
    """Per-sample bisection of the rate-dependent PI (slopes in ``[m_lo, m_hi]``, > 0)."""
    n = r.shape[0]
    for k in range(y.shape[0]):
        yk = y[k]
        ref = up if has_prev else 0.0
        f0 = _rd_eval(ref, r, w, p0, k_rate, up, has_prev, z)
        if yk >= f0:
            lo = ref + (yk - f0) / m_hi
            hi = ref + (yk - f0) / m_lo
        else:
            lo = ref + (yk - f0) / m_lo
            hi = ref + (yk - f0) / m_hi
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            if mid == lo or mid == hi:
                break
            if _rd_eval(mid, r, w, p0, k_rate, up, has_prev, z) < yk:
                lo = mid
            else:
                hi = mid
        uk = 0.5 * (lo + hi)
        extra = k_rate * abs(uk - up) if has_prev else 0.0
        for i in range(n):
            ri = r[i] + extra
            zi = z[i]
            if zi > uk + ri:
                zi = uk + ri
            if zi < uk - ri:
                zi = uk - ri
            z[i] = zi
        up = uk
        has_prev = True
        out[k] = uk
    return up


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
    fields: ClassVar[tuple[Field, ...]] = (
        *PIModel.fields[:3],  # p0, the static thresholds r_i and the weights p_i
        Field("beta_s", "number", doc="threshold increase per unit input rate (s)",
              title="Rate sensitivity β",
              control=Control("β", "s", (0.0, 2.0), lower=0.0, scale=1e-4)),
        PIModel.fields[3],  # state0
    )
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

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Operators x samples of work; the play outputs are kept as a ``(samples,
        operators)`` matrix before they are weighted, so memory is operators + 4 sample
        arrays (measured: operators + 2). Work in element operations, memory in bytes."""
        n, k = float(samples), float(np.size(self.thresholds))
        return RunCost(n * (1.0 + self.field_size()), SAMPLE_BYTES * (n * (k + 4.0) + 4.0 * k))

    def slope_bounds(self, dt: float) -> tuple[float, float]:
        """Smallest and largest slope of the per-sample map ``u_k -> y_k`` at ``dt``.

        Each play output moves with slope 0, ``1 - κ`` or ``1 + κ`` in ``u_k`` (``κ = β/dt``).
        """
        kap = self.beta_s / float(dt)
        cand = np.stack((np.zeros_like(self.weights), self.weights * (1 - kap),
                         self.weights * (1 + kap)))
        return float(self.p0 + cand.min(axis=0).sum()), float(self.p0 + cand.max(axis=0).sum())

    def inverse(self) -> RateDependentPIInverse:
        """Per-sample inverse (bisection, see :class:`RateDependentPIInverse`).

        Raises
        ------
        NotInvertibleError
            If the static model is not invertible (a slope ``<= 0``).
        """
        self.static.inverse()  # the static slope rules, with their messages
        return RateDependentPIInverse(self.p0, self.thresholds, self.weights, self.beta_s,
                                      self.state0)


@register_model
@dataclass(frozen=True, eq=False)
class RateDependentPIInverse(Model):
    """Inverse of a :class:`RateDependentPI`, solved sample by sample.

    At each sample the forward map ``u_k -> y_k`` (plays and previous input fixed) is
    piecewise linear with slopes in ``[m_lo, m_hi]`` (:meth:`RateDependentPI.slope_bounds`);
    with ``m_lo > 0`` it is strictly increasing, so ``u_k`` is bracketed from one evaluation
    and bisected to adjacent doubles (at most 100 steps). Tolerance: ``|forward(u_k) - y_k|
    <= m_hi · ulp(u_k)``, i.e. about 1e-15 relative. The state is the forward model's state
    ``(play outputs, previous input)``, so the two stay consistent.

    Parameters
    ----------
    p0, thresholds, weights, beta_s, state0
        The model being inverted (see :class:`RateDependentPI`).
    """

    type_name: ClassVar[str] = "rate-inverse"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = RateDependentPI.fields
    p0: float
    thresholds: Float1D
    weights: Float1D
    beta_s: float
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        fwd = RateDependentPI(self.p0, self.thresholds, self.weights, self.beta_s, self.state0)
        for k in ("p0", "thresholds", "weights", "beta_s", "state0"):
            object.__setattr__(self, k, getattr(fwd, k))

    @property
    def forward(self) -> RateDependentPI:
        """The model being inverted."""
        return RateDependentPI(self.p0, self.thresholds, self.weights, self.beta_s, self.state0)

    def checked_slopes(self, dt: float) -> tuple[float, float]:
        """Slope bounds at ``dt``, checked to be positive."""
        return checked_rate_slopes("rate-dependent PI", self.forward.slope_bounds(dt),
                                   self.beta_s, dt)

    def default_state(self) -> tuple[Float1D, None]:
        return (np.array(self.state0, copy=True), None)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        m_lo, m_hi = self.checked_slopes(float(dt))  # type: ignore[arg-type]
        z0, up = state
        z = np.array(z0, dtype=np.float64, copy=True)
        out = np.empty_like(u)
        up_f = _rd_inverse(u, self.thresholds, self.weights, self.p0,
                           self.beta_s / float(dt), m_lo, m_hi,  # type: ignore[arg-type]
                           0.0 if up is None else float(up), up is not None, z, out)
        return out, (z, float(up_f) if (u.size or up is not None) else None)

    def inverse(self) -> RateDependentPI:
        return self.forward

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Operators x samples x solver iterations (each over every operator; typically
        well under the cap of 100 per sample); work in element operations, memory in
        bytes."""
        n, k = float(samples), float(np.size(self.thresholds))
        return RunCost(60.0 * n * (k + 1.0), SAMPLE_BYTES * (2.0 * n + 4.0 * k))


# ----------------------------------------------------------------------------- initial memory
#: Models made of a bank of play operators with ``thresholds`` and ``state0`` fields.
_PLAY_BANK_MODELS = (PIModel, RateDependentPI, PreisachModel, RateDependentPreisach)


@register_model
@dataclass(frozen=True, eq=False)
class InitialMemory(Model):
    """A hysteresis model whose memory at the first sample comes from a virtual input history.

    The PI memory is the alternating sequence of dominant past input extrema, so an unknown
    initial state is parametrised by a few virtual extrema ``history`` applied (quasi-
    statically) before the record starts (missing-physics notes, E8). The inverse is the
    inverse of the wrapped model started in the consistent state (the one reached by the
    output of the same history).

    Parameters
    ----------
    model : PIModel, RateDependentPI or PreisachModel
        The hysteresis model: a bank of play operators with ``thresholds`` and ``state0``.
    history : array_like of shape (m,)
        Virtual input extrema (input units), applied in order before the first sample.
    """

    type_name: ClassVar[str] = "initial-memory"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("history", "numbers", doc="virtual input extrema before the record",
              title="Input history u_k", control=Control("u{i}", "input", (-1.25, 1.25))),
        Field("model", "model",
              doc="the hysteresis model ('pi', 'rate', 'preisach' or 'rate-preisach')"),
    )
    model: Model
    history: Float1D

    def __post_init__(self) -> None:
        if not isinstance(self.model, _PLAY_BANK_MODELS):
            raise ParameterError(
                "initial-memory wraps a 'pi', 'rate', 'preisach' or 'rate-preisach' model (a bank "
                f"of play operators), got {type(self.model).__name__}"
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
        return dataclasses.replace(self.model, state0=self.play_state)  # type: ignore[type-var]

    def as_chain(self) -> Chain:
        """The one-stage chain of :meth:`with_state` (how the C export sees it)."""
        return Chain((self.with_state(),))

    def default_state(self) -> Any:
        return self.with_state().default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        return self.with_state()._run(u, state, dt)

    def inverse(self) -> Model:
        return self.with_state().inverse()


# ----------------------------------------------------------------------------- preview
@dataclass(frozen=True)
class CausalForm:
    """A compensator that runs sample by sample, fed the desired trajectory ahead of time.

    Attributes
    ----------
    model : Model
        The compensator with every :class:`Advance` replaced by a causal :class:`Delay` and
        every :class:`Drift` behind it started ``preview`` samples early.
    preview : int
        Samples of preview: at step ``k`` feed the desired sample ``k + preview``; the output
        is the drive for sample ``k`` (the first ``preview`` outputs are warm-up).
    """

    model: Model
    preview: int


def causal_form(model: Model, dt: float | None) -> CausalForm:
    """The real-time form of a compensator that may hold advances (inverses of delays).

    Parameters
    ----------
    model : Model
        Typically ``forward.inverse()``.
    dt : float or None
        Sample spacing in seconds (needed when the model holds an advance).

    Returns
    -------
    CausalForm
        ``model`` unchanged with ``preview = 0`` when it has no advance.
    """
    stages = list(model.stages) if isinstance(model, Chain) else [model]
    if not any(isinstance(s, Advance) for s in stages):
        return CausalForm(model, 0)
    assert dt is not None
    out: list[Model] = []
    ahead = 0  # preview consumed by the advances seen so far (samples)
    for s in stages:
        if isinstance(s, Advance):
            ahead += s.preview_samples(dt)
            out.append(s.causal(dt))
        elif isinstance(s, Drift) and ahead:
            out.append(Drift(s.coefficients, s.span_s, s.start_s - ahead * dt))
        else:
            out.append(s)
    return CausalForm(Chain(tuple(out)) if len(out) > 1 else out[0], ahead)
