"""A Preisach model with a level-dependent density, in the play form (missing-physics E10).

Why plays describe a Preisach model
-----------------------------------
A relay with switching thresholds ``β <= α`` has half-width ``r = (α - β)/2`` and centre
``s = (α + β)/2``. Driven by ``u`` it is "up" once ``u`` has risen above ``s + r`` and "down"
once ``u`` has fallen below ``s - r``. The play ``z = Γ_r[u]`` follows ``u - r`` while ``u``
rises and ``u + r`` while it falls, so ``z > s`` exactly when the relay is up: every relay of
half-width ``r`` is read off the one play of threshold ``r``.

With the relay density ``μ(r, s)`` the Preisach output is an integral over relays. For the
relays of one band of half-widths around ``r_i`` the contribution is a function of the play
output alone, ``F_i(z_i) = ∫ 2 μ_i(s) 1{s < z_i} ds + const``, whose slope at ``z = s`` is
(twice) the density of relays centred at ``s``. This module takes ``μ_i`` piecewise constant
in the centre ``s`` between level knots ``e_0 < ... < e_{m-2}``, so ``F_i`` is piecewise
linear with slope ``W[i, j]`` on segment ``j``::

    y(t) = Σ_i Σ_j W[i, j] seg_j(z_i(t)),     z_i = Γ_{r_i}[u]

    seg_0(z)     = min(z, e_0)                          (slope 1 below e_0)
    seg_j(z)     = clip(z, e_{j-1}, e_j) - e_{j-1}      (slope 1 on [e_{j-1}, e_j])
    seg_{m-1}(z) = max(z, e_{m-2}) - e_{m-2}            (slope 1 above e_{m-2})

(``seg_0(z) = z`` when ``m = 1``). The segments sum to ``z``, so a weight row that is the
same on every segment is a PI play, and ``W[i, :] = p_i`` with ``r_0 = 0`` is the PI model
``p0 = W[0, 0]`` (:meth:`PreisachModel.from_pi`). With ``W >= 0`` the density is
non-negative: a discrete Preisach model whose minor loops of equal amplitude need not be
congruent at different bias levels (a minor loop around ``s`` opens plays whose outputs sit
in the segments near ``s``), which the PI model cannot represent.

Inverse
-------
Given the play states, the output is a continuous, piecewise-linear, non-decreasing function
of the current input; with the reversible play ``r_0 = 0`` and every ``W[0, j] > 0`` it is
strictly increasing and onto, so each desired output has exactly one input. The inverse
(:class:`PreisachInverse`) solves for it sample by sample on the linear piece that holds it
(:func:`core.kernels.preisach_inverse`) and advances the plays.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D, Float2D
from .base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from .exceptions import NotInvertibleError, ParameterError
from .kernels import _level_sum, njit, play_update
from .pi import PIModel
from .validation import as_finite_scalar, as_matrix, as_state_vector, as_vector, filled

__all__ = ["PreisachInverse", "PreisachModel", "RateDependentPreisach",
           "RateDependentPreisachInverse", "level_segments"]


def level_segments(z: ArrayLike, knots: ArrayLike) -> Float2D:
    """The level-segment functions ``seg_j(z)`` (see the module docstring).

    Parameters
    ----------
    z : array_like of shape (M,)
        Play outputs (input units).
    knots : array_like of shape (m - 1,)
        Increasing level knots (input units); empty for one segment.

    Returns
    -------
    ndarray of shape (M, m)
        ``seg_j(z)``; the rows sum to ``z``.
    """
    z = np.asarray(z, dtype=np.float64).reshape(-1)
    e = np.asarray(knots, dtype=np.float64).reshape(-1)
    m = e.size + 1
    out = np.empty((z.size, m))
    if m == 1:
        out[:, 0] = z
        return out
    if kernels.NUMBA_ENABLED:
        # one compiled pass, bit-identical to the numpy form below (several times faster:
        # the diagnosis levels play banks of ~10^6 entries per trial initial memory)
        return kernels.level_segments_rows(z, e, out)
    out[:, 0] = np.minimum(z, e[0])
    for j in range(1, m - 1):
        out[:, j] = np.clip(z, e[j - 1], e[j]) - e[j - 1]
    out[:, m - 1] = np.maximum(z, e[m - 2]) - e[m - 2]
    return out


#: The rate coefficient β of the rate-dependent models (:class:`RateDependentPreisach`,
#: :class:`core.stages.RateDependentPI`): how much every threshold widens per unit input rate.
RATE_FIELD = Field("beta_s", "number", doc="threshold increase per unit input rate (s)",
                   title="Rate sensitivity β",
                   control=Control("β", "s", (0.0, 2.0), lower=0.0, scale=1e-4))


def as_rate_coefficient(beta_s: Any) -> float:
    """``beta_s`` as a finite number ``>= 0`` (:class:`ParameterError` otherwise)."""
    b = as_finite_scalar(beta_s, "beta_s")
    if b < 0:
        raise ParameterError(f"beta_s = {b:g} must be >= 0 (thresholds cannot shrink with rate)")
    return b


def checked_rate_slopes(what: str, bounds: tuple[float, float], beta_s: float, dt: float
                        ) -> tuple[float, float]:
    """The slope bounds ``(m_lo, m_hi)`` of a rate-dependent model at sample time ``dt`` (s),
    or :class:`NotInvertibleError` naming ``what`` when the smallest is not positive (the
    per-sample map is then not monotone in the current input)."""
    m_lo, m_hi = bounds
    if not m_lo > 0:
        raise NotInvertibleError(
            f"{what} at dt={dt:g} s is not monotone in the current input (smallest slope "
            f"{m_lo:g} <= 0, beta_s/dt = {beta_s / dt:g}); sample more slowly or reduce beta_s"
        )
    return m_lo, m_hi


class _PlaysOnLevels:
    """The sizes of a Preisach model in the play form (:class:`PreisachModel` and
    :class:`RateDependentPreisach`): its plays and its level segments."""

    thresholds: Float1D
    knots: Float1D

    @property
    def n(self) -> int:
        """Number of play operators (threshold bands)."""
        return int(self.thresholds.size)

    @property
    def n_segments(self) -> int:
        """Number of level segments ``m = len(knots) + 1``."""
        return int(self.knots.size + 1)


@register_model
@dataclass(frozen=True, eq=False)
class PreisachModel(_PlaysOnLevels, Model):
    """Preisach model ``y = Σ_i Σ_j W[i, j] seg_j(Γ_{r_i}[u])`` (level-dependent density).

    Parameters
    ----------
    thresholds : array_like of shape (n,)
        Play thresholds ``0 <= r_0 < r_1 < ... < r_{n-1}`` (input units); ``r_0 = 0`` is
        the reversible part (a play of threshold 0 is the identity).
    weights : array_like of shape (n, m)
        ``W[i, j] >= 0``: slope of play ``i``'s contribution while its output lies in level
        segment ``j`` (output units per input unit), i.e. twice the relay density of
        half-width band ``i`` centred in segment ``j``.
    knots : array_like of shape (m - 1,), optional
        Strictly increasing interior level knots (input units); empty (default) for one
        segment, which is a PI model.
    state0 : array_like of shape (n,), optional
        Play outputs before the first sample (as :class:`core.pi.PIModel`: zeros by
        default, a scalar is broadcast to every play).

    Examples
    --------
    >>> m = PreisachModel([0.0, 0.5], [[1.0, 1.0], [0.2, 0.6]], knots=[0.0])
    >>> m.is_invertible, m.n, m.n_segments
    (True, 2, 2)
    """

    type_name: ClassVar[str] = "preisach"
    estimator: ClassVar[str | None] = "core.fitting:PreisachRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("thresholds", "numbers",
              doc="play thresholds r_i (input units), increasing, r_0 may be 0",
              title="Thresholds r_i", increasing=True, index_base=0,
              control=Control("r{i}", "input", (0.0, 1.25), lower=0.0)),
        Field("weights", "matrix",
              doc="W[i][j] >= 0: slope of play i on level segment j (output per input unit)",
              title="Weights W_ij", index_base=0,
              control=Control("W{i},{j}", "output/input", (0.0, 1.5), lower=0.0)),
        Field("knots", "numbers", optional=True, default=(),
              doc="interior level knots e_j (input units), increasing; none = PI",
              title="Level knots e_j", increasing=True, scale_with=("thresholds",),
              control=Control("e{i}", "input", (-1.25, 1.25))),
        Field("state0", "numbers", optional=True, doc="play outputs before the first sample",
              title="Initial play outputs z_i(0)", index_base=0, scale_with=("thresholds",),
              control=Control("z{i}(0)", "input", (-1.25, 1.25))),
    )
    thresholds: Float1D
    weights: Float2D
    knots: Float1D = ()  # type: ignore[assignment]
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        r = as_vector(self.thresholds, "thresholds", nonnegative=True, increasing=True)
        e = as_vector(self.knots, "knots", min_length=0, increasing=True)
        w = as_matrix(self.weights, "weights", nonnegative=True)
        if w.shape != (r.size, e.size + 1):
            raise ParameterError(
                f"weights must have shape ({r.size}, {e.size + 1}): one row per threshold "
                f"({r.size}) and one column per level segment (len(knots) + 1 = {e.size + 1}), "
                f"got {w.shape}"
            )
        object.__setattr__(self, "thresholds", r)
        object.__setattr__(self, "knots", e)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "state0", as_state_vector(self.state0, r.size))

    @classmethod
    def from_pi(cls, pi: PIModel, knots: ArrayLike = ()) -> PreisachModel:
        """The Preisach form of a PI model with non-negative weights (same output).

        ``thresholds = (0, r_1, ..., r_n)``, every segment of row 0 weighted ``p0`` and of
        row ``i`` weighted ``p_i``; the plays start at the PI model's ``state0`` (the
        reversible play's state is irrelevant: it equals the input after one sample).

        Raises
        ------
        ParameterError
            If a PI weight or ``p0`` is negative (a Preisach density is non-negative).
        """
        e = as_vector(knots, "knots", min_length=0, increasing=True)
        p = np.concatenate(([pi.p0], pi.weights))
        return cls(
            np.concatenate(([0.0], pi.thresholds)),
            np.repeat(p[:, None], e.size + 1, axis=1),
            e,
            np.concatenate(([0.0], filled(pi.state0))),
        )

    # ------------------------------------------------------------------ properties
    @property
    def is_invertible(self) -> bool:
        """Whether ``r_0 == 0`` and every reversible weight ``W[0, j] > 0`` (branches rise)."""
        return bool(self.thresholds[0] == 0 and (self.weights[0] > 0).all())

    def check_invertible(self) -> None:
        """Raise ``NotInvertibleError`` naming the failed rule (see :attr:`is_invertible`)."""
        if self.thresholds[0] != 0:
            raise NotInvertibleError(
                f"Preisach model is not invertible: r0 = {self.thresholds[0]:g} "
                "must be 0 (the reversible play makes every branch strictly increasing)"
            )
        bad = np.flatnonzero(self.weights[0] <= 0)
        if bad.size:
            j = int(bad[0])
            raise NotInvertibleError(
                f"Preisach model is not invertible: W0,{j} = "
                f"{self.weights[0, j]:g} must be > 0 (the reversible slope on level segment "
                f"{j}; with it 0 the output is flat there after a reversal)"
            )

    def level_functions(self, z: ArrayLike) -> Float2D:
        """Each play's contribution ``F_i(z) = Σ_j W[i, j] seg_j(z)``, shape ``(M, n)``.

        Parameters
        ----------
        z : array_like of shape (M,)
            Play output values (input units).
        """
        return level_segments(z, self.knots) @ self.weights.T

    def output_bound(self, u_max: float) -> float:
        """Upper bound on ``|y|`` for ``|u| <= u_max`` from any state (after the first sample).

        Each play output lies in ``[u - r_i, u + r_i]`` and ``F_i`` is non-decreasing, so
        ``|y| <= Σ_i max(|F_i(u_max + r_i)|, |F_i(-u_max - r_i)|)``.
        """
        a = abs(float(u_max)) + self.thresholds
        hi = np.diag(self.level_functions(a))
        lo = np.diag(self.level_functions(-a))
        return float(np.sum(np.maximum(np.abs(hi), np.abs(lo))))

    # ------------------------------------------------------------------ simulation
    def default_state(self) -> Float1D:
        return np.array(self.state0, copy=True)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        z = np.array(as_vector(state, "state", length=self.n), copy=True)
        y = np.empty(u.size)
        kernels.preisach_output(u, self.thresholds, self.knots, self.weights, z, y)
        return y, z

    def operator_outputs(self, u: ArrayLike, state: ArrayLike | None = None) -> Float2D:
        """Each play operator's output, shape ``(N, n)``."""
        from .operators import play_bank

        return play_bank(u, self.thresholds, self.state0 if state is None else state)[0]

    # ------------------------------------------------------------------ inverse
    def inverse(self) -> PreisachInverse:
        """The exact inverse, solved sample by sample from the same play states.

        Raises
        ------
        NotInvertibleError
            If ``thresholds[0] != 0`` or some ``weights[0][j] <= 0`` (the message names it).
        """
        return PreisachInverse(self)


@register_model
@dataclass(frozen=True, eq=False)
class PreisachInverse(Model):
    """Exact inverse of a :class:`PreisachModel`, solved sample by sample.

    Its state is the forward model's play states (started at the forward ``state0``): for
    each desired output the unique input that produces it from the current states is found
    on the linear piece that holds it (:func:`core.kernels.preisach_inverse`), then the plays
    advance to that input, so ``model(PreisachInverse(model)(y)) == y`` to round-off.

    Parameters
    ----------
    model : PreisachModel
        The invertible forward model (``thresholds[0] == 0``, every ``weights[0][j] > 0``).
    """

    type_name: ClassVar[str] = "preisach-inverse"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("model", "model", doc="the Preisach model being inverted"),
    )
    model: PreisachModel

    def __post_init__(self) -> None:
        if not isinstance(self.model, PreisachModel):
            raise ParameterError(
                f"preisach-inverse.model must be a 'preisach' model, got "
                f"{type(self.model).__name__}"
            )
        self.model.check_invertible()

    def default_state(self) -> Float1D:
        return self.model.default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        m = self.model
        z = np.array(as_vector(state, "state", length=m.n), copy=True)
        x = np.empty(u.size)
        buf = np.empty(2 * m.n * m.n_segments)
        kernels.preisach_inverse(u, m.thresholds, m.knots, m.weights, z, buf, x)
        return x, z

    def inverse(self) -> PreisachModel:
        """The forward model."""
        return self.model

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Operators x segments per sample (the solve scans every breakpoint); work in
        element operations, memory in bytes."""
        m = self.model
        n, k = float(samples), float(m.n) * float(m.n_segments)
        return RunCost(50.0 * n * (k + 1.0), SAMPLE_BYTES * (2.0 * n + 2.0 * k))


# ----------------------------------------------------------------------------- rate-dependent
@njit(cache=True, nogil=True, inline="always")
def rate_bracket(yk, f0, ref, m_lo, m_hi):  # pragma: no cover - compiled
    """Where the input of a rate-dependent model's output ``yk`` lies, from its output ``f0``
    at the input ``ref`` and the slope bounds ``[m_lo, m_hi]`` (``m_lo > 0``): ``(lo, hi)``."""
    if yk >= f0:
        return ref + (yk - f0) / m_hi, ref + (yk - f0) / m_lo
    return ref + (yk - f0) / m_lo, ref + (yk - f0) / m_hi


@njit(cache=True, nogil=True)
def _rate_eval(x, r, e, W, k_rate, up, has_prev, zin, zout, write):  # pragma: no cover
    """Output of the rate-dependent Preisach at input ``x`` from the plays ``zin`` (previous
    input ``up``); the new plays go to ``zout`` when ``write``."""
    extra = k_rate * abs(x - up) if has_prev else 0.0
    acc = 0.0
    for i in range(r.shape[0]):
        if r[i] == 0.0:
            zi = x  # the reversible play stays the identity at any rate
        else:
            zi = play_update(zin[i], x, r[i] + extra)
        if write:
            zout[i] = zi
        acc += _level_sum(zi, e, W, i)
    return acc


@njit(cache=True, nogil=True)
def _rate_output(u, r, e, W, k_rate, up, has_prev, z, out):  # pragma: no cover - compiled
    """:func:`_rate_eval` sample by sample (plays ``z`` updated in place)."""
    for k in range(u.shape[0]):
        out[k] = _rate_eval(u[k], r, e, W, k_rate, up, has_prev, z, z, True)
        up = u[k]
        has_prev = True


@njit(cache=True, nogil=True)
def _rate_inverse(y, r, e, W, k_rate, m_lo, m_hi, up, has_prev, z, out):  # pragma: no cover
    """Per-sample bisection of :func:`_rate_eval` (slopes in ``[m_lo, m_hi]``, ``m_lo > 0``):
    the step from the previous input to the solution is bracketed by the slope bounds and
    bisected to adjacent doubles (at most 100 steps); the plays then advance."""
    for k in range(y.shape[0]):
        yk = y[k]
        ref = up if has_prev else 0.0
        f0 = _rate_eval(ref, r, e, W, k_rate, up, has_prev, z, z, False)
        lo, hi = rate_bracket(yk, f0, ref, m_lo, m_hi)
        for _ in range(100):
            mid = 0.5 * (lo + hi)
            if mid == lo or mid == hi:
                break
            if _rate_eval(mid, r, e, W, k_rate, up, has_prev, z, z, False) < yk:
                lo = mid
            else:
                hi = mid
        uk = 0.5 * (lo + hi)
        _rate_eval(uk, r, e, W, k_rate, up, has_prev, z, z, True)
        up = uk
        has_prev = True
        out[k] = uk
    return up


@register_model
@dataclass(frozen=True, eq=False)
class RateDependentPreisach(_PlaysOnLevels, Model):
    """Preisach model whose relay thresholds move apart with the input rate.

    ``y = Σ_i Σ_j W[i, j] seg_j(Γ_{r_i + β|u̇|}[u])``: the :class:`PreisachModel` (level-
    dependent density) with the additive rate-dependent thresholds of
    :class:`core.stages.RateDependentPI` (relay switching points ``s ± (r + β|u̇|)``). A play
    of threshold 0 is the reversible part and stays the identity at any rate, so the model
    differs from a delay. The rate is the backward difference ``(u_k - u_{k-1}) / dt``
    (none at the first sample); the state is ``(play outputs, previous input)``.

    Parameters
    ----------
    thresholds, weights, knots, state0
        As in :class:`PreisachModel` (``weights`` of shape ``(n, len(knots) + 1)``).
    beta_s : float
        Rate coefficient β in seconds, ``>= 0`` (threshold increase per unit input rate).

    Examples
    --------
    >>> m = RateDependentPreisach([0.0, 0.5], [[1.0, 1.0], [0.2, 0.6]], 1e-4, knots=[0.0])
    >>> m.static.n_segments, m.beta_s
    (2, 0.0001)
    """

    type_name: ClassVar[str] = "rate-preisach"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        *PreisachModel.fields[:2],  # thresholds, weights
        RATE_FIELD,
        *PreisachModel.fields[2:],  # knots, state0
    )
    thresholds: Float1D
    weights: Float2D
    beta_s: float
    knots: Float1D = ()  # type: ignore[assignment]
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        base = PreisachModel(self.thresholds, self.weights, self.knots, self.state0)
        for k in ("thresholds", "weights", "knots", "state0"):
            object.__setattr__(self, k, getattr(base, k))
        object.__setattr__(self, "beta_s", as_rate_coefficient(self.beta_s))

    @property
    def static(self) -> PreisachModel:
        """The rate-independent Preisach model (β = 0)."""
        return PreisachModel(self.thresholds, self.weights, self.knots, self.state0)

    def default_state(self) -> tuple[Float1D, None]:
        return (np.array(self.state0, copy=True), None)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        z0, up = state
        z = np.array(as_vector(z0, "state", length=self.n), copy=True)
        y = np.empty(u.size)
        _rate_output(u, self.thresholds, self.knots, self.weights, self.beta_s / float(filled(dt)),
                     0.0 if up is None else float(up), up is not None, z, y)
        return y, (z, float(u[-1]) if u.size else up)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Operators x segments per sample; work in element operations, memory in bytes."""
        n, k = float(samples), float(self.n) * float(self.n_segments)
        return RunCost(n * (1.0 + k + self.n), SAMPLE_BYTES * (2.0 * n + 2.0 * k))

    def slope_bounds(self, dt: float) -> tuple[float, float]:
        """Smallest and largest slope of the per-sample map ``u_k -> y_k`` at ``dt``.

        A play of threshold 0 moves with slope 1, another with 0, ``1 - κ`` or ``1 + κ``
        (``κ = β/dt``); its contribution's slope lies within its row of ``W``.
        """
        kap = self.beta_s / float(dt)
        w = np.asarray(self.weights)
        rev = self.thresholds == 0
        lo = float(np.sum(w[rev].min(axis=1)))
        hi = float(np.sum(w[rev].max(axis=1)))
        wmax = w[~rev].max(axis=1) if (~rev).any() else np.zeros(0)
        lo += float(np.sum(np.minimum(0.0, (1.0 - kap) * wmax)))
        hi += float(np.sum((1.0 + kap) * wmax))
        return lo, hi

    def inverse(self) -> RateDependentPreisachInverse:
        """Per-sample inverse (bisection, see :class:`RateDependentPreisachInverse`).

        Raises
        ------
        NotInvertibleError
            If the static model is not invertible (the rules of :class:`PreisachModel`).
        """
        self.static.check_invertible()
        return RateDependentPreisachInverse(self)


@register_model
@dataclass(frozen=True, eq=False)
class RateDependentPreisachInverse(Model):
    """Inverse of a :class:`RateDependentPreisach`, solved sample by sample.

    At each sample the forward map ``u_k -> y_k`` (plays and previous input fixed) is
    piecewise linear with slopes in ``[m_lo, m_hi]`` (:meth:`RateDependentPreisach.
    slope_bounds`); with ``m_lo > 0`` it is strictly increasing, so ``u_k`` is bracketed from
    one evaluation and bisected to adjacent doubles. The state is the forward model's.

    Parameters
    ----------
    model : RateDependentPreisach
        The forward model (its static part invertible).
    """

    type_name: ClassVar[str] = "rate-preisach-inverse"
    needs_dt: ClassVar[bool] = True
    fields: ClassVar[tuple[Field, ...]] = (
        Field("model", "model", doc="the rate-dependent Preisach model being inverted"),
    )
    model: RateDependentPreisach

    def __post_init__(self) -> None:
        if not isinstance(self.model, RateDependentPreisach):
            raise ParameterError(
                "rate-preisach-inverse.model must be a 'rate-preisach' model, got "
                f"{type(self.model).__name__}"
            )
        self.model.static.check_invertible()

    def checked_slopes(self, dt: float) -> tuple[float, float]:
        """Slope bounds at ``dt``, checked to be positive."""
        return checked_rate_slopes("rate-dependent Preisach model",
                                   self.model.slope_bounds(dt), self.model.beta_s, dt)

    def default_state(self) -> tuple[Float1D, None]:
        return self.model.default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        m = self.model
        m_lo, m_hi = self.checked_slopes(float(filled(dt)))
        z0, up = state
        z = np.array(as_vector(z0, "state", length=m.n), copy=True)
        out = np.empty(u.size)
        up_f = _rate_inverse(u, m.thresholds, m.knots, m.weights, m.beta_s / float(filled(dt)),
                             m_lo, m_hi, 0.0 if up is None else float(up), up is not None, z,
                             out)
        return out, (z, float(up_f) if (u.size or up is not None) else None)

    def inverse(self) -> RateDependentPreisach:
        """The forward model."""
        return self.model

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Operators x segments x bisection steps per sample; work in element operations,
        memory in bytes."""
        m = self.model
        n, k = float(samples), float(m.n) * float(m.n_segments)
        return RunCost(60.0 * n * (k + 1.0), SAMPLE_BYTES * (2.0 * n + 2.0 * k))
