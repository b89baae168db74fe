"""Continuous-time linear dynamics as a :class:`~core.base.Model` (exact zero-order hold).

:class:`LinearSystem` holds a transfer function ``G(s) = num(s) / den(s)`` (coefficients in
descending powers of ``s``, time in seconds). For simulation it builds one state-space
realization ``(A, B, C, D)`` and discretises it exactly for a zero-order-hold input:

``x[k+1] = Ad x[k] + Bd u[k]``, ``y[k] = C x[k] + D u[k]``, with
``[[Ad, Bd], [0, 1]] = expm([[A, B], [0, 0]] dt)``.

The state ``x`` is the continuous-time state of that fixed realization at the sample
instants, so it does not depend on ``dt``: chunked simulation equals one call, and a record
may even change its sample spacing between chunks.

Numerics for stiff, badly scaled polynomials (paper 001 eq. 38 has coefficients from 1 to
8.8e16): the polynomials are first rescaled in frequency (``s = ω0 σ`` with
``ω0 = |a_n / a_0|^(1/n)``), so the scaled coefficients are O(1); the companion realization
of the scaled system is then balanced with exact power-of-two scaling
(``scipy.linalg.matrix_balance``) before being mapped back to seconds. The discrete poles
(eigenvalues of ``Ad``) equal ``exp(p dt)`` of the continuous poles to rounding.

Effects built on top of this (delay approximations, lags, resonances) can subclass it or
construct it with :meth:`LinearSystem.from_zpk`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D, Float2D
from .base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from .exceptions import NotInvertibleError, ParameterError
from .validation import as_finite_scalar, as_vector, filled, frozen

__all__ = ["InverseLinearSystem", "LinearSystem", "lti_run"]


def _lti_run_py(Ad, Bd, C, D, x, u, y):  # pragma: no cover - compiled twin below
    """Simulate ``x+ = Ad x + Bd u``, ``y = C x + D u``; ``x`` is updated in place.

    Parameters
    ----------
    Ad : ndarray of shape (n, n)
    Bd, C : ndarray of shape (n,)
    D : float
    x : ndarray of shape (n,)
        State before the first sample; overwritten with the state after the last.
    u, y : ndarray of shape (N,)
        Input and output buffer.
    """
    n = x.shape[0]
    tmp = np.empty(n)
    for k in range(u.shape[0]):
        uk = u[k]
        acc = D * uk
        for i in range(n):
            acc += C[i] * x[i]
        y[k] = acc
        for i in range(n):
            s = Bd[i] * uk
            for j in range(n):
                s += Ad[i, j] * x[j]
            tmp[i] = s
        for i in range(n):
            x[i] = tmp[i]


if kernels.NUMBA_ENABLED:
    from numba import njit

    lti_run = njit(cache=True, nogil=True)(_lti_run_py)
else:  # pragma: no cover
    lti_run = _lti_run_py


def _strip(c: Float1D) -> Float1D:
    nz = np.flatnonzero(c != 0)
    return c[nz[0]:] if nz.size else c[-1:]


def _state_space_cost(order: int, samples: int) -> RunCost:
    """A state-space run: ``order^2`` per sample plus the discretisation (``order^3``);
    work in element operations, memory in bytes."""
    n, k = float(samples), float(order)
    return RunCost(n * (k * k + 2.0 * k + 2.0) + 50.0 * (k + 1.0) ** 3,
                   SAMPLE_BYTES * (2.0 * n + 8.0 * (k + 1.0) ** 2))


@register_model
@dataclass(frozen=True, eq=False)
class LinearSystem(Model):
    """Continuous-time transfer function ``G(s) = num(s) / den(s)``, simulated with exact ZOH.

    Parameters
    ----------
    num : array_like of shape (m+1,)
        Numerator coefficients, highest power of ``s`` first (output units per input unit,
        times s^k). Leading zeros are dropped.
    den : array_like of shape (n+1,)
        Denominator coefficients, highest power first; ``n >= m`` (proper system).
    state0 : array_like of shape (n,), optional
        State of the internal realization before the first sample (zeros: at rest).
        Use :meth:`rest_state` to start in equilibrium with a constant input.

    Examples
    --------
    >>> g = LinearSystem([1.0], [0.01, 1.0])      # first-order lag, τ = 10 ms
    >>> g.dc_gain
    1.0
    >>> y = g([1.0] * 5, dt=0.01)                 # step response 1 - exp(-k dt/τ)
    >>> round(float(y[1]), 6)
    0.632121
    """

    type_name: ClassVar[str] = "lti"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("num", "numbers", doc="numerator in s, highest power first",
              title="Numerator coefficients", index_base=0,
              control=Control("b{i}", "s^k", (-1.5, 1.5))),
        Field("den", "numbers", doc="denominator in s, highest power first",
              title="Denominator coefficients", index_base=0,
              control=Control("a{i}", "s^k", (-1.5, 1.5))),
        Field("state0", "numbers", optional=True, doc="initial state", title="Initial state",
              control=Control("x{i}(0)", "1", (-1.5, 1.5))),
    )
    needs_dt: ClassVar[bool] = True
    num: Float1D
    den: Float1D
    state0: Float1D | None = None
    _cache: dict[float, tuple[Float2D, Float1D]] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )
    #: the realization :meth:`state_space` gives, made once in ``__post_init__``
    _ss: tuple[Float2D, Float1D, Float1D, float] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        num = _strip(np.asarray(as_vector(self.num, "num")))
        den = _strip(np.asarray(as_vector(self.den, "den")))
        if den[0] == 0:
            raise ParameterError("the denominator a must have a nonzero coefficient (it is 0)")
        if num.size > den.size:
            raise ParameterError(
                f"the numerator b has degree {num.size - 1} but the denominator a only "
                f"{den.size - 1} (leading zeros such as a0 = 0 lower it): the transfer function "
                "is improper (not causal); give b a degree no higher than a's"
            )
        object.__setattr__(self, "num", frozen(num))
        object.__setattr__(self, "den", frozen(den))
        n = den.size - 1
        if self.state0 is None:
            s0 = frozen(np.zeros(n))
        elif n == 0:
            s0 = frozen(as_vector(self.state0, "state0", min_length=0, length=0))
        else:
            s0 = as_vector(self.state0, "state0", length=n)
        object.__setattr__(self, "state0", s0)
        A, B, C, D = self._realize()
        object.__setattr__(self, "_ss", (A, B, C, D))

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_zpk(
        cls, zeros: ArrayLike, poles: ArrayLike, gain: float
    ) -> LinearSystem:
        """Build from zeros, poles (rad/s, complex pairs conjugate) and gain ``k``.

        ``G(s) = k Π(s - z_i) / Π(s - p_j)``.

        Raises
        ------
        ParameterError
            If complex zeros/poles do not come in conjugate pairs.
        """
        z = np.atleast_1d(np.asarray(zeros, dtype=complex))
        p = np.atleast_1d(np.asarray(poles, dtype=complex))
        k = as_finite_scalar(gain, "gain")
        num = k * np.poly(z) if z.size else np.array([k])
        den = np.poly(p) if p.size else np.array([1.0])
        for name, c in (("zeros", num), ("poles", den)):
            if np.max(np.abs(np.imag(c))) > 1e-9 * max(1.0, float(np.max(np.abs(c)))):
                raise ParameterError(f"{name} must come in complex-conjugate pairs")
        return cls(np.real(num), np.real(den))

    def _realize(self) -> tuple[Float2D, Float1D, Float1D, float]:
        from scipy.linalg import matrix_balance

        num, den = self.num / self.den[0], self.den / self.den[0]
        n = den.size - 1
        numf = np.concatenate((np.zeros(n + 1 - num.size), num))
        D = float(numf[0])
        if n == 0:
            return np.zeros((0, 0)), np.zeros(0), np.zeros(0), D
        # frequency scaling s = w0*sigma makes the coefficients O(1)
        w0 = abs(den[-1]) ** (1.0 / n) if den[-1] != 0 else 1.0
        powers = w0 ** np.arange(n + 1)
        a = den / powers  # monic in sigma
        b = numf / powers
        b_strict = b[1:] - b[0] * a[1:]  # strictly proper part numerator, length n
        A = np.zeros((n, n))
        A[0, :] = -a[1:]
        A[np.arange(1, n), np.arange(n - 1)] = 1.0
        B = np.zeros(n)
        B[0] = 1.0
        C = b_strict.copy()
        # A_bal = T^-1 A T with T = diag(scale), powers of two: exact, no rounding
        _, (T, _) = matrix_balance(A, permute=False, separate=True)
        Ab = A * T[None, :] / T[:, None]
        Bb = B / T
        Cb = C * T
        return frozen(w0 * Ab), frozen(w0 * Bb), frozen(Cb), D

    # ------------------------------------------------------------------ properties
    @property
    def order(self) -> int:
        """Number of states ``n`` (degree of the denominator)."""
        return int(self.den.size - 1)

    @property
    def relative_degree(self) -> int:
        """``deg(den) - deg(num)``; > 0 means strictly proper."""
        return int(self.den.size - self.num.size) if np.any(self.num != 0) else self.order

    @property
    def is_strictly_proper(self) -> bool:
        """Whether ``G(s) → 0`` as ``s → ∞`` (no direct feedthrough, ``D = 0``)."""
        return self.state_space()[3] == 0.0

    @property
    def poles(self) -> np.ndarray:
        """Roots of ``den`` in rad/s, shape ``(n,)`` (complex)."""
        return np.roots(self.den) if self.order else np.zeros(0, dtype=complex)

    @property
    def zeros(self) -> np.ndarray:
        """Roots of ``num`` in rad/s (complex)."""
        return np.roots(self.num) if self.num.size > 1 else np.zeros(0, dtype=complex)

    @property
    def is_stable(self) -> bool:
        """Whether every pole has a negative real part."""
        return bool(np.all(self.poles.real < 0))

    @property
    def dc_gain(self) -> float:
        """``G(0) = num(0) / den(0)`` (output units per input unit).

        Raises
        ------
        ParameterError
            If ``G`` has a pole at ``s = 0`` (integrator: infinite DC gain).
        """
        if self.den[-1] == 0:
            raise ParameterError("dc_gain is infinite: den(0) = 0 (pole at s = 0)")
        return float(self.num[-1] / self.den[-1])

    def frequency_response(self, f: ArrayLike) -> np.ndarray:
        """Complex ``G(j 2π f)`` for frequencies ``f`` in Hz, same shape as ``f``."""
        s = 2j * np.pi * np.asarray(f, dtype=np.float64)
        return np.polyval(self.num, s) / np.polyval(self.den, s)

    def state_space(self) -> tuple[Float2D, Float1D, Float1D, float]:
        """The (balanced) continuous realization ``(A, B, C, D)`` used for simulation.

        Returns
        -------
        A : ndarray of shape (n, n), 1/s
        B, C : ndarray of shape (n,)
        D : float
        """
        return self._ss

    def discretize(self, dt: float) -> tuple[Float2D, Float1D, Float1D, float]:
        """Exact zero-order-hold discretisation at sample spacing ``dt`` (cached per ``dt``).

        Parameters
        ----------
        dt : float
            Seconds, > 0.

        Returns
        -------
        Ad : ndarray of shape (n, n)
        Bd, C : ndarray of shape (n,)
        D : float
        """
        from scipy.linalg import expm

        dt = as_finite_scalar(dt, "dt", positive=True)
        A, B, C, D = self.state_space()
        hit = self._cache.get(dt)
        if hit is None:
            n = self.order
            M = np.zeros((n + 1, n + 1))
            M[:n, :n] = A * dt
            M[:n, n] = B * dt
            E = expm(M) if n else np.eye(1)
            hit = (frozen(E[:n, :n]), frozen(E[:n, n]))
            if len(self._cache) > 16:
                self._cache.clear()
            self._cache[dt] = hit
        return hit[0], hit[1], C, D

    def rest_state(self, u0: float) -> Float1D:
        """State of equilibrium under the constant input ``u0`` (``x = -A⁻¹ B u0``).

        Raises
        ------
        ParameterError
            If ``A`` is singular (pole at ``s = 0``): no equilibrium for ``u0 != 0``.
        """
        A, B, _, _ = self.state_space()
        if self.order == 0:
            return np.zeros(0)
        try:
            return np.asarray(np.linalg.solve(A, -B * float(u0)), dtype=np.float64)
        except np.linalg.LinAlgError as exc:
            raise ParameterError(
                "rest_state needs a nonsingular A; this system has a pole at s = 0"
            ) from exc

    # ------------------------------------------------------------------ simulation
    def default_state(self) -> Float1D:
        return np.array(self.state0, copy=True)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        assert dt is not None
        Ad, Bd, C, D = self.discretize(dt)
        x = _state_vector(state, self.order)
        y = np.empty(u.size)
        lti_run(Ad, Bd, C, D, x, u, y)
        return y, x

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Order squared per sample (a dense state update) plus the discretisation."""
        return _state_space_cost(self.order, samples)

    def inverse(self) -> InverseLinearSystem:
        """Exact inverse of the sampled system (biproper, minimum-phase systems only).

        The inverse runs the ZOH-discretised forward system backwards
        (``u[k] = (y[k] - C x[k]) / D``) and carries the *forward* state, so
        ``(G >> G.inverse())(u, dt=dt) == u`` to rounding for every ``dt``.

        Raises
        ------
        NotInvertibleError
            If ``G`` is strictly proper (relative degree > 0: the inverse would need
            derivatives of the input), or has a zero with ``Re(z) >= 0`` (the inverse would
            be unstable).
        """
        if self.is_strictly_proper:
            raise NotInvertibleError(
                f"LinearSystem is strictly proper (relative degree {self.relative_degree} > 0, "
                "D = 0); its inverse would differentiate the input, so it is not invertible"
            )
        bad = [z for z in self.zeros if z.real >= 0]
        if bad:
            raise NotInvertibleError(
                f"LinearSystem has a zero at s = {bad[0]:.6g} with Re >= 0 (non-minimum "
                "phase); its inverse would be unstable"
            )
        return InverseLinearSystem(self)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "type": self.type_name,
            "num": self.num.tolist(),
            "den": self.den.tolist(),
        }
        if np.any(filled(self.state0) != 0):
            d["state0"] = filled(self.state0).tolist()
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> LinearSystem:
        missing = [k for k in ("num", "den") if k not in d]
        if missing:
            raise ParameterError(f"lti model is missing field(s): {', '.join(missing)}")
        return cls(d["num"], d["den"], d.get("state0"))


def _state_vector(state: Any, n: int) -> Float1D:
    if n == 0:
        return np.zeros(0)
    return np.array(as_vector(state, "state", length=n), copy=True)


@register_model
@dataclass(frozen=True, eq=False)
class InverseLinearSystem(Model):
    """Exact inverse of a biproper :class:`LinearSystem` at the sample instants.

    Parameters
    ----------
    system : LinearSystem
        The forward system (``D != 0``); the state carried is the forward system's state.
    """

    type_name: ClassVar[str] = "lti_inverse"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("system", "model", doc="the biproper system being inverted"),
    )
    needs_dt: ClassVar[bool] = True
    system: LinearSystem

    def __post_init__(self) -> None:
        if not isinstance(self.system, LinearSystem):
            raise ParameterError("system must be a LinearSystem")
        if self.system.is_strictly_proper:
            raise NotInvertibleError("system is strictly proper (D = 0); it has no inverse")

    def default_state(self) -> Float1D:
        return self.system.default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        assert dt is not None
        Ad, Bd, C, D = self.system.discretize(dt)
        Ai = np.ascontiguousarray(Ad - np.outer(Bd, C) / D)
        x = _state_vector(state, self.system.order)
        y = np.empty(u.size)
        lti_run(Ai, Bd / D, -C / D, 1.0 / D, x, u, y)
        return y, x

    def inverse(self) -> LinearSystem:
        return self.system

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """As the system inverted (:meth:`LinearSystem.cost`)."""
        return _state_space_cost(self.system.order, samples)

    def to_dict(self) -> dict[str, Any]:
        return {"type": self.type_name, "system": self.system.to_dict()}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> InverseLinearSystem:
        sys_d = d.get("system")
        if not isinstance(sys_d, dict):
            raise ParameterError("lti_inverse.system must be an lti model object")
        return cls(LinearSystem.from_dict(sys_d))
