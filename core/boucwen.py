"""Rate-independent Bouc-Wen hysteresis: a bank of elements integrated in the input.

Element ``j`` has the hysteretic variable ``z_j`` (input units) driven by the input ``u``,

    dz_j/du = 1 - (beta_j sign(du z_j) + gamma_j) |z_j|^n_j,

(the Bouc-Wen law with ``alpha = 1``, written in the input instead of time, so the output
depends on the sequence of input values only). With ``beta_j >= 0`` and ``beta_j + gamma_j > 0``
the variable saturates at ``z_s = (beta_j + gamma_j)^(-1/n_j)`` and never leaves
``[-z_s, z_s]`` from a start inside it; ``beta_j > |gamma_j|`` gives the usual loop.

The registered model :class:`BoucWenModel` (``"bouc-wen"``) is ``y = k u + sum_j c_j z_j``
with each element described by quantities a user can read off a loop: its saturation
``z_s`` (input units), its slope ``s = dz/du`` right after a reversal from saturation
(``s = 2 beta / (beta + gamma)``) and the exponent ``n``; :meth:`BoucWenModel.from_classical`
takes the literature's ``beta, gamma, n``. Its inverse, :class:`BoucWenInverse`, is solved
sample by sample (:func:`core.kernels.bouc_wen_inverse`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D, Float2D
from .base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from .exceptions import NotInvertibleError, ParameterError
from .validation import as_finite_scalar, as_input_signal, as_state_vector, as_vector

__all__ = [
    "MAX_SUBSTEPS",
    "STEPS_PER_SATURATION",
    "BoucWenInverse",
    "BoucWenModel",
    "BoucWenState",
    "bouc_wen_states",
    "saturation_levels",
]

#: Most RK4 sub-steps per sample of the registered model (a longer jump takes longer
#: sub-steps; the variables stay inside their saturation bounds).
MAX_SUBSTEPS = 16
#: The model's sub-step is ``z_s / (STEPS_PER_SATURATION n max(1, |s - 1|))`` of its
#: stiffest element: about 1e-7 of ``z_s`` from the exact solution.
STEPS_PER_SATURATION = 16.0
#: Work units of one element's sub-step priced by :meth:`BoucWenModel.cost`: four rate
#: evaluations with a power each (a power is some 20-40 ns; benchmarks/bench_cost.py).
_SUBSTEP_WORK = 32.0
#: Sub-steps per sample priced: the most there can be (smooth inputs take one or two).
_PRICED_SUBSTEPS = float(MAX_SUBSTEPS)
#: Output evaluations per sample priced for the inverse's solve (typically 6-12; the
#: bracket's widening and the Illinois steps are capped at 200).
_PRICED_SOLVES = 14.0


@dataclass(frozen=True, eq=False)
class BoucWenState:
    """Where a bank of Bouc-Wen elements stands: the last input and each hysteretic variable.

    Attributes
    ----------
    u : float
        The last input value (input units); the next sample is integrated from it.
    z : ndarray of shape (m,)
        Hysteretic variable of each element at that input (input units).
    """

    u: float
    z: Float1D


def saturation_levels(beta: ArrayLike, gamma: ArrayLike, n: ArrayLike) -> Float1D:
    """Saturation ``z_s = (beta + gamma)^(-1/n)`` of each element, ``inf`` where
    ``beta + gamma <= 0`` (no bound).

    Returns
    -------
    ndarray of shape (m,)
        Input units.
    """
    s = np.asarray(beta, dtype=np.float64) + np.asarray(gamma, dtype=np.float64)
    e = np.asarray(n, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(s > 0, np.abs(s) ** (-1.0 / e), np.inf)
    return np.asarray(out, dtype=np.float64)


def bouc_wen_states(
    u: ArrayLike,
    beta: ArrayLike,
    gamma: ArrayLike,
    n: ArrayLike,
    z0: ArrayLike | None = None,
    *,
    max_step: float,
    u0: float | None = None,
    max_substeps: int = 0,
) -> tuple[Float2D, BoucWenState]:
    """Hysteretic variables of a bank of rate-independent Bouc-Wen elements.

    Each ``z_j`` is integrated along the input path with classical RK4 in the input, in
    ``ceil(|du| / max_step)`` equal sub-steps between consecutive samples (so a large jump,
    such as a staircase's step, is integrated as accurately as a slow ramp), and kept inside
    ``[-z_s, z_s]`` (:func:`saturation_levels`), which the exact solution never leaves.

    Parameters
    ----------
    u : array_like of shape (N,)
        Input samples (input units).
    beta, gamma : array_like of shape (m,)
        Shape parameters of each element (input units to the power ``-n_j``).
    n : array_like of shape (m,)
        Exponents, ``>= 1``.
    z0 : array_like of shape (m,), optional
        Hysteretic variables before the first sample (zeros by default).
    max_step : float
        Largest RK4 sub-step (input units), ``> 0``.
    u0 : float, optional
        Input before the first sample: the integration starts there. By default ``u[0]``
        (``z`` at the first sample is ``z0``).
    max_substeps : int
        Most sub-steps per sample (0: no limit); a longer jump takes longer sub-steps.

    Returns
    -------
    Z : ndarray of shape (N, m)
        ``Z[k, j] = z_j`` after sample ``k``.
    state : BoucWenState
        The last input and the variables after it: continue a record with
        ``bouc_wen_states(u_next, ..., z0=state.z, u0=state.u)``.

    Raises
    ------
    ParameterError
        If a parameter is not finite, the lengths differ, ``n < 1`` or ``max_step <= 0``.

    Examples
    --------
    >>> Z, st = bouc_wen_states([0.0, 1.0], [0.5], [0.5], [1.0], max_step=0.01)
    >>> round(float(Z[1, 0]), 6)  # 1 - exp(-1)
    0.632121
    """
    x = as_input_signal(u)
    b = as_vector(beta, "beta")
    g = as_vector(gamma, "gamma", length=b.size)
    e = as_vector(n, "n", length=b.size)
    if (e < 1).any():
        j = int(np.flatnonzero(e < 1)[0])
        raise ParameterError(f"n[{j}] = {e[j]:g} must be >= 1 (the exponent of |z|)")
    z = (
        np.zeros(b.size)
        if z0 is None
        else np.array(as_vector(z0, "z0", length=b.size), dtype=np.float64, copy=True)
    )
    h = as_finite_scalar(max_step, "max_step", positive=True)
    start = (float(x[0]) if x.size else 0.0) if u0 is None else as_finite_scalar(u0, "u0")
    out = np.empty((x.size, b.size))
    kernels.bouc_wen_bank(
        x,
        start,
        np.ascontiguousarray(b),
        np.ascontiguousarray(g),
        np.ascontiguousarray(e),
        saturation_levels(b, g, e),
        h,
        int(max_substeps),
        z,
        out,
    )
    last = float(x[-1]) if x.size else start
    return out, BoucWenState(last, z)


def _state_of(state: Any, m: int) -> tuple[float, Float1D]:
    """``(u, z)`` of a state given as a :class:`BoucWenState` or a pair (checked)."""
    if isinstance(state, BoucWenState):
        u, z = state.u, state.z
    elif isinstance(state, (tuple, list)) and len(state) == 2:
        u, z = state
    else:
        raise ParameterError(
            "a bouc-wen state is the last input and the element variables, "
            f"BoucWenState(u, z) or (u, z); got {type(state).__name__}"
        )
    x = as_finite_scalar(u, "state.u")
    zz = np.array(as_vector(z, "state.z", length=m), dtype=np.float64, copy=True)
    return x, zz


@register_model
@dataclass(frozen=True, eq=False)
class BoucWenModel(Model):
    """Rate-independent Bouc-Wen model ``y = k u + Σ_j c_j z_j`` (a bank of elements).

    Element ``j`` follows ``dz_j/du = 1 - (β_j sign(du z_j) + γ_j) |z_j|^n_j`` along the
    input path (``α = 1``: the weights carry the scale), with ``β_j + γ_j = z_s,j^-n_j`` and
    ``2 β_j / (β_j + γ_j) = s_j``. Right after a reversal from saturation ``dz_j/du = s_j``;
    towards saturation it falls to 0, so every ``dz_j/du`` lies in ``[0, max(1, s_j)]``.
    Integrated with RK4 in the input (sub-steps of at most :attr:`substep`, at most
    :data:`MAX_SUBSTEPS` per sample). With ``c_j < 0`` and ``s_j > 1`` the loop runs
    counter-clockwise (below on the way up), like a piezo actuator's.

    Parameters
    ----------
    k : float
        Reversible slope (output units per input unit).
    weights : array_like of shape (m,)
        Element weights ``c_j`` (output units per input unit).
    saturation : array_like of shape (m,)
        Saturation ``z_s,j > 0`` of each element (input units).
    reversal_slope : array_like of shape (m,)
        ``s_j = dz_j/du`` right after a reversal from saturation, ``0 <= s_j <= 10``
        (1: ``β = γ``; 2: ``γ = 0``; 0: no hysteresis).
    exponent : array_like of shape (m,)
        Smoothness ``n_j``, ``1 <= n_j <= 10`` (large: sharp corners).
    state0 : array_like of shape (m,), optional
        Element variables at input ``input0`` before the first sample, ``|z_j| <= z_s,j``
        (zeros by default; a scalar is broadcast).
    input0 : float
        Input at which ``state0`` holds: the first sample is integrated from it (0 by
        default).

    Examples
    --------
    >>> m = BoucWenModel.from_classical(1.0, [-0.4], [0.03], [0.01], [1.0])
    >>> m.saturation.tolist(), m.reversal_slope.tolist()
    ([25.0, 1.5])
    """

    type_name: ClassVar[str] = "bouc-wen"
    estimator: ClassVar[str | None] = "core.fitting:BoucWenRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field(
            "k",
            "number",
            doc="reversible slope (output per input unit)",
            title="Reversible slope k",
            scale_with=("weights",),
            control=Control("k", "output/input", (-0.5, 1.5)),
        ),
        Field(
            "weights",
            "numbers",
            doc="element weights c_j (output per input unit)",
            title="Weights c_j",
            scale_with=("k",),
            control=Control("c{i}", "output/input", (-1.5, 1.5)),
        ),
        Field(
            "saturation",
            "numbers",
            doc="saturation z_s of each element (input units), > 0",
            title="Saturations z_s,j",
            control=Control("zs{i}", "input", (0.0, 1.25), lower=0.0, strict=True),
        ),
        Field(
            "reversal_slope",
            "numbers",
            doc="dz/du right after a reversal from saturation, 0 to 10 (2 beta/(beta+gamma))",
            title="Reversal slopes s_j",
            control=Control(
                "s{i}", "1", (0.0, 3.0), step=0.01, relative=False, lower=0.0, upper=10.0
            ),
        ),
        Field(
            "exponent",
            "numbers",
            doc="smoothness exponent n_j, 1 to 10",
            title="Exponents n_j",
            control=Control(
                "n{i}", "1", (1.0, 4.0), step=0.01, relative=False, lower=1.0, upper=10.0
            ),
        ),
        Field(
            "state0",
            "numbers",
            optional=True,
            doc="element variables z_j at input0 before the first sample (input units)",
            title="Initial variables z_j(0)",
            scale_with=("saturation",),
            control=Control("z{i}(0)", "input", (-1.25, 1.25)),
        ),
        Field(
            "input0",
            "number",
            optional=True,
            default=0.0,
            doc="input at which state0 holds (input units)",
            title="Initial input u(0)",
            control=Control("u(0)", "input", (-1.25, 1.25)),
        ),
    )
    k: float
    weights: Float1D
    saturation: Float1D
    reversal_slope: Float1D
    exponent: Float1D
    state0: Float1D | None = None
    input0: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "k", as_finite_scalar(self.k, "k"))
        c = as_vector(self.weights, "weights")
        m = c.size
        zs = as_vector(self.saturation, "saturation", length=m, positive=True)
        s = as_vector(self.reversal_slope, "reversal_slope", length=m, nonnegative=True)
        e = as_vector(self.exponent, "exponent", length=m)
        for name, v, hi in (("reversal_slope", s, 10.0), ("exponent", e, 10.0)):
            if (v > hi).any():
                j = int(np.flatnonzero(v > hi)[0])
                raise ParameterError(
                    f"{name}[{j}] = {v[j]:g} must be <= {hi:g} (a stiffer element needs "
                    "impractically small integration steps)"
                )
        if (e < 1).any():
            j = int(np.flatnonzero(e < 1)[0])
            raise ParameterError(
                f"exponent[{j}] = {e[j]:g} must be >= 1 (the power of |z| in the Bouc-Wen law)"
            )
        z0 = as_state_vector(self.state0, m)
        over = np.abs(z0) > zs
        if over.any():
            j = int(np.flatnonzero(over)[0])
            raise ParameterError(
                f"state0[{j}] = {z0[j]:g} lies outside the element's saturation "
                f"±{zs[j]:g}: no input history reaches it; use a value inside"
            )
        for name, v in (
            ("weights", c),
            ("saturation", zs),
            ("reversal_slope", s),
            ("exponent", e),
            ("state0", z0),
        ):
            object.__setattr__(self, name, v)
        object.__setattr__(self, "input0", as_finite_scalar(self.input0, "input0"))

    @classmethod
    def from_classical(
        cls,
        k: float,
        weights: ArrayLike,
        beta: ArrayLike,
        gamma: ArrayLike,
        n: ArrayLike,
        state0: ArrayLike | None = None,
        input0: float = 0.0,
    ) -> BoucWenModel:
        """The model of the literature's shape parameters (``α = 1``).

        Parameters
        ----------
        k, weights, state0, input0
            As the class.
        beta, gamma : array_like of shape (m,)
            ``β_j >= 0`` and ``β_j + γ_j > 0`` (input units to the power ``-n_j``).
        n : array_like of shape (m,)
            Exponents.

        Raises
        ------
        ParameterError
            If ``β_j < 0`` or ``β_j + γ_j <= 0`` (the variable would be unbounded).
        """
        b = as_vector(beta, "beta")
        g = as_vector(gamma, "gamma", length=b.size)
        e = as_vector(n, "n", length=b.size)
        bad = (b < 0) | (b + g <= 0)
        if bad.any():
            j = int(np.flatnonzero(bad)[0])
            raise ParameterError(
                f"beta[{j}] = {b[j]:g}, gamma[{j}] = {g[j]:g}: need beta >= 0 and "
                "beta + gamma > 0 (otherwise z grows without bound)"
            )
        s0 = None if state0 is None else np.asarray(state0, dtype=np.float64)
        return cls(k, np.asarray(weights, dtype=np.float64), (b + g) ** (-1.0 / e),
                   2.0 * b / (b + g), e, s0, input0)

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of elements."""
        return int(self.weights.size)

    @property
    def beta(self) -> Float1D:
        """``β_j = s_j z_s,j^-n_j / 2``."""
        return 0.5 * self.reversal_slope * self.saturation ** (-self.exponent)

    @property
    def gamma(self) -> Float1D:
        """``γ_j = (2 - s_j) z_s,j^-n_j / 2``."""
        return 0.5 * (2.0 - self.reversal_slope) * self.saturation ** (-self.exponent)

    @property
    def substep(self) -> float:
        """Largest RK4 sub-step (input units): ``min_j z_s,j / (16 n_j max(1, |s_j - 1|))``,
        a sixteenth of the stiffest element's relaxation length."""
        stiff = self.exponent * np.maximum(1.0, np.abs(self.reversal_slope - 1.0))
        return float(np.min(self.saturation / (STEPS_PER_SATURATION * stiff)))

    def slope_bounds(self) -> tuple[float, float]:
        """Smallest and largest ``dy/du``: ``k + Σ_j c_j [0, max(1, s_j)]``."""
        top = self.weights * np.maximum(1.0, self.reversal_slope)
        return (
            float(self.k + np.sum(np.minimum(top, 0.0))),
            float(self.k + np.sum(np.maximum(top, 0.0))),
        )

    @property
    def is_invertible(self) -> bool:
        """Whether the output rises with the input on every branch (smallest slope > 0)."""
        return self.slope_bounds()[0] > 0

    def _kernel_args(self) -> tuple[Any, ...]:
        return (
            self.beta,
            self.gamma,
            np.ascontiguousarray(self.exponent),
            self.saturation,
            self.substep,
            MAX_SUBSTEPS,
        )

    # ------------------------------------------------------------------ simulation
    def default_state(self) -> BoucWenState:
        return BoucWenState(self.input0, np.array(self.state0, copy=True))

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, BoucWenState]:
        x, z = _state_of(state, self.n)
        y = np.empty(u.size)
        kernels.bouc_wen_output(u, x, self.k, self.weights, *self._kernel_args(), z, y)
        return y, BoucWenState(float(u[-1]) if u.size else x, z)

    def states(self, u: ArrayLike, state: Any = None) -> Float2D:
        """Each element's variable ``z_j`` after each sample, shape ``(N, m)``."""
        x, z = _state_of(self.default_state() if state is None else state, self.n)
        uu = as_input_signal(u)
        out = np.empty((uu.size, self.n))
        kernels.bouc_wen_bank(uu, x, *self._kernel_args(), z, out)
        return out

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Elements x RK4 sub-steps per sample (priced at the most there can be,
        :data:`MAX_SUBSTEPS`); work in element operations, memory in bytes."""
        n, m = float(samples), float(self.n)
        return RunCost(
            n * (1.0 + m * _PRICED_SUBSTEPS * _SUBSTEP_WORK),
            SAMPLE_BYTES * (self.run_arrays * n + 6.0 * m),
        )

    # ------------------------------------------------------------------ inverse
    def check_invertible(self) -> None:
        """Raise ``NotInvertibleError`` naming the failed rule (see :attr:`is_invertible`)."""
        lo, _ = self.slope_bounds()
        if not lo > 0:
            raise NotInvertibleError(
                f"Bouc-Wen model is not invertible: its smallest slope k + sum of c_j "
                f"max(1, s_j) over the negative weights is {lo:g}; it must be > 0, or the "
                "output falls while the input rises on some branch (raise k or shrink the "
                "negative weights)"
            )

    def inverse(self) -> BoucWenInverse:
        """The compensator: the input whose output is the desired one, sample by sample.

        Raises
        ------
        NotInvertibleError
            If the smallest slope ``dy/du`` is not positive (the message gives it).
        """
        return BoucWenInverse(self)


@register_model
@dataclass(frozen=True, eq=False)
class BoucWenInverse(Model):
    """Inverse of a :class:`BoucWenModel`, solved sample by sample.

    From the forward state (last input, element variables) the output is a continuous
    function of the next input with slope in :meth:`BoucWenModel.slope_bounds`, positive for
    an invertible model; the input is bracketed from those slopes and found by regula falsi
    (Illinois) to adjacent doubles, then the variables advance to it. The state is the
    forward model's, so ``model(BoucWenInverse(model)(y)) == y`` to the round-off of the
    solve (the sub-step count jumps with the input move, so the discrete output can jump by
    the integration error, about 1e-9 of the output range, where it changes).

    Parameters
    ----------
    model : BoucWenModel
        The invertible forward model.
    """

    type_name: ClassVar[str] = "bouc-wen-inverse"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("model", "model", doc="the Bouc-Wen model being inverted"),
    )
    model: BoucWenModel

    def __post_init__(self) -> None:
        if not isinstance(self.model, BoucWenModel):
            raise ParameterError(
                f"bouc-wen-inverse.model must be a 'bouc-wen' model, got "
                f"{type(self.model).__name__}"
            )
        self.model.check_invertible()

    def default_state(self) -> BoucWenState:
        return self.model.default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, BoucWenState]:
        m = self.model
        x, z = _state_of(state, m.n)
        lo, hi = m.slope_bounds()
        out = np.empty(u.size)
        last = kernels.bouc_wen_inverse(
            u, x, m.k, m.weights, *m._kernel_args(), lo, hi, z, np.empty(m.n), out
        )
        return out, BoucWenState(float(last), z)

    def inverse(self) -> BoucWenModel:
        """The forward model."""
        return self.model

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """The forward run's work times the output evaluations of the solve (work in element
        operations, memory in bytes)."""
        f = self.model.cost(samples, dt)
        return RunCost(_PRICED_SOLVES * f.work, f.memory)
