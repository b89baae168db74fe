"""The classical Prandtl–Ishlinskii model and its analytical inverse (paper 001 eq. 18-37)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D
from .base import Control, Field, Model, register_model
from .exceptions import NotInvertibleError, ParameterError
from .validation import as_finite_scalar, as_input_signal, as_state_vector, as_vector, filled

__all__ = ["PIModel", "inverse_parameters"]


def inverse_parameters(
    p0: float, thresholds: Float1D, weights: Float1D
) -> tuple[float, Float1D, Float1D]:
    """Thresholds and weights of the inverse PI model (paper 001 eq. 36-37).

    ``z_i = sum_{g=0..i} p_g (r_i - r_g)``, ``q0 = 1/p0``,
    ``q_i = -p_i / (S_{i+1} S_i)`` with the slopes ``S_i = p0 + p_1 + ... + p_{i-1}``.

    Parameters
    ----------
    p0 : float
        Linear weight, must be > 0.
    thresholds, weights : ndarray of shape (n,)

    Returns
    -------
    q0 : float
    z : ndarray of shape (n,)
    q : ndarray of shape (n,)

    Raises
    ------
    NotInvertibleError
        If ``p0 <= 0`` or a cumulative slope ``p0 + p_1 + ... + p_i <= 0``.
    """
    r = np.asarray(thresholds, dtype=np.float64)
    p = np.asarray(weights, dtype=np.float64)
    if p0 <= 0:
        raise NotInvertibleError(
            f"PI model is not invertible: p0 = {p0:g} must be > 0 (slope S1 = p0 is the "
            "slope right after every reversal)"
        )
    S = p0 + np.cumsum(p)  # S[i] = p0 + p_1 + ... + p_{i+1}  (slope S_{i+2})
    if (S <= 0).any():
        i = int(np.flatnonzero(S <= 0)[0])
        terms = " + ".join(["p0"] + [f"p{g}" for g in range(1, i + 2)])
        raise NotInvertibleError(
            f"PI model is not invertible: slope S{i + 2} = {terms} = {S[i]:g} "
            "must be > 0 (every loop segment must rise)"
        )
    S_prev = np.concatenate(([p0], S[:-1]))
    q = -p / (S * S_prev)
    # z_i = phi(r_i): p0*r_i + sum_{g<=i} p_g (r_i - r_g)
    z = p0 * r + np.array([np.sum(p[: i + 1] * (r[i] - r[: i + 1])) for i in range(r.size)])
    return 1.0 / p0, z, q


@register_model
@dataclass(frozen=True, eq=False)
class PIModel(Model):
    """Classical PI model ``y = p0*u + sum_i p_i Γ_{r_i}[u]`` (paper 001 eq. 21).

    Parameters
    ----------
    p0 : float
        Weight of the linear (r = 0) term; ``p0 > 0`` for an invertible model.
    thresholds : array_like of shape (n,)
        Play thresholds ``0 < r_1 < ... < r_n`` (input units).
    weights : array_like of shape (n,)
        Play weights ``p_i`` (output units per input unit). Negative weights are
        allowed (the inverse of a PI model has them) as long as you do not need the
        inverse; :meth:`inverse` checks that every slope stays positive.
    state0 : array_like of shape (n,), optional
        Play outputs before the first sample (the paper's M0, Fig. 9); zeros by default.
        A scalar is broadcast to every operator.

    Examples
    --------
    >>> m = PIModel(0.72, [0.45, 0.9], [0.6, 0.48])
    >>> m.slopes.tolist()
    [0.72, 1.32, 1.8]
    """

    type_name: ClassVar[str] = "pi"
    estimator: ClassVar[str | None] = "core.fitting:PIRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("p0", "number", doc="weight of the linear term", title="Linear weight p0",
              control=Control("p0", "output/input", (-0.5, 1.5)), scale_with=("weights",)),
        Field("thresholds", "numbers", doc="play thresholds r_i (input units), increasing",
              title="Thresholds r_i", increasing=True,
              control=Control("r{i}", "input", (0.0, 1.25), lower=0.0, strict=True)),
        Field("weights", "numbers", doc="play weights p_i", title="Weights p_i",
              control=Control("p{i}", "output/input", (-0.5, 1.5)), scale_with=("p0",)),
        Field("state0", "numbers", optional=True, doc="play outputs before the first sample",
              title="Initial play outputs z_i(0)", scale_with=("thresholds",),
              control=Control("z{i}(0)", "input", (-1.25, 1.25))),
    )
    p0: float
    thresholds: Float1D
    weights: Float1D
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "p0", as_finite_scalar(self.p0, "p0"))
        r = as_vector(self.thresholds, "thresholds", positive=True, increasing=True)
        w = as_vector(self.weights, "weights", length=r.size)
        object.__setattr__(self, "thresholds", r)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "state0", as_state_vector(self.state0, r.size))

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of play operators."""
        return int(self.thresholds.size)

    @property
    def slopes(self) -> Float1D:
        """Loop-segment slopes ``S_1..S_{n+1}`` = cumulative sums of ``(p0, p1, ..., pn)`` (eq. 33).

        Returns
        -------
        ndarray of shape (n+1,)
        """
        return np.cumsum(np.concatenate(([self.p0], self.weights)))

    @property
    def max_loop_width(self) -> float:
        """Maximum loop width in input units, ``2 Σ p_i r_i / (p0 + Σ p_i)`` (eq. 32, corrected).

        The printed eq. (32) omits p0 from the denominator; Example 1's σ = 1.5 needs it
        (1.518 with p0, 2.12 without; see shared/notes/seed-notes.md).
        """
        return float(2.0 * np.dot(self.weights, self.thresholds) / self.slopes[-1])

    def loading_curve(self, r: ArrayLike) -> Float1D:
        """Initial loading curve φ(r) = p0 r + Σ_{r_g < r} p_g (r − r_g) (eq. 22), odd in r.

        Parameters
        ----------
        r : array_like of shape (M,)
            Input travel from the virgin state.

        Returns
        -------
        ndarray of shape (M,)
        """
        x = np.asarray(r, dtype=np.float64)
        a = np.abs(x)
        phi = self.p0 * a + np.sum(
            self.weights * np.maximum(a[..., None] - self.thresholds, 0.0), axis=-1
        )
        return np.sign(x) * phi

    def output_bound(self, u_max: float) -> float:
        """Upper bound on ``|y|`` for ``|u| <= u_max`` and virgin state (eq. 31)."""
        pmax = float(np.max(np.abs(self.weights)))
        return (abs(self.p0) + self.n * pmax) * u_max + self.n * pmax * float(self.thresholds[-1])

    @property
    def is_invertible(self) -> bool:
        """Whether ``p0 > 0`` and every slope is positive."""
        return bool(self.p0 > 0 and (self.slopes > 0).all())

    # ------------------------------------------------------------------ simulation
    def default_state(self) -> Float1D:
        return np.array(self.state0, copy=True)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        z = np.array(as_vector(state, "state", length=self.n), copy=True)
        y = np.empty(u.size)
        kernels.pi_output_fast(u, self.thresholds, self.weights, self.p0, z, y)
        return y, z

    def simulate_strict(
        self, u: ArrayLike, state: ArrayLike | None = None
    ) -> tuple[Float1D, Float1D]:
        """Deterministic (sequential-sum) evaluation; bit-identical to :mod:`core.reference`.

        Returns
        -------
        y : ndarray of shape (N,)
        state : ndarray of shape (n,)
        """
        u = as_input_signal(u)
        z = np.array(self.state0 if state is None else as_vector(state, "state", length=self.n))
        y = np.empty(u.size)
        kernels.pi_output_strict(u, self.thresholds, self.weights, self.p0, z, y)
        return y, z

    def operator_outputs(self, u: ArrayLike, state: ArrayLike | None = None) -> Float1D:
        """Each play operator's output, shape ``(N, n)`` (the stacked contributions / p_i)."""
        from .operators import play_bank

        return play_bank(u, self.thresholds, self.state0 if state is None else state)[0]

    # ------------------------------------------------------------------ inverse
    def inverse(self) -> PIModel:
        """Analytical inverse PI model (eq. 35-37), with a consistent initial state.

        The inverse's play states are those reached by the output of a virtual input
        history that leaves this model in ``state0`` (uniform ``state0 = c`` maps to
        ``(p0 + Σ p_i) c``), so ``self(self.inverse()(u)) == u`` from the first sample.

        Raises
        ------
        NotInvertibleError
            If ``p0 <= 0`` or some slope ``S_i <= 0`` (the message names it), or if
            ``state0`` is not reachable by any input history.
        """
        q0, z, q = inverse_parameters(self.p0, self.thresholds, self.weights)
        inv0 = _inverse_state(self, z, q0, q)
        return PIModel(q0, z, q, inv0)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "type": self.type_name,
            "p0": self.p0,
            "thresholds": self.thresholds.tolist(),
            "weights": self.weights.tolist(),
        }
        if np.any(filled(self.state0) != 0):
            d["state0"] = filled(self.state0).tolist()
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> PIModel:
        missing = [k for k in ("p0", "thresholds", "weights") if k not in d]
        if missing:
            raise ParameterError(f"pi model is missing field(s): {', '.join(missing)}")
        return cls(d["p0"], d["thresholds"], d["weights"], d.get("state0"))


def state_history(thresholds: Float1D, state: Float1D, tol: float = 1e-9) -> Float1D:
    """An input history that brings a bank of play operators to ``state``.

    Starting from the uniform state ``c = state[-1]`` (all operators equal to the widest
    one), the input moves to ``state[i] ± r_i`` for ``i = n-2, ..., 0`` so operator ``i``
    lands on its target without disturbing the wider ones.

    Parameters
    ----------
    thresholds : ndarray of shape (n,)
        Increasing thresholds.
    state : ndarray of shape (n,)
        Target play outputs.

    Returns
    -------
    ndarray of shape (m,)
        Input history; the first value is ``c`` (play operators start at ``c``).

    Raises
    ------
    NotInvertibleError
        If no input history reaches ``state`` (the state violates
        ``|z_i - z_j| <= |r_i - r_j|``).
    """
    r = np.asarray(thresholds, dtype=np.float64)
    target = np.asarray(state, dtype=np.float64)
    c = float(target[-1])
    z = np.full(r.size, c)
    hist = [c]
    for i in range(r.size - 2, -1, -1):
        if target[i] < z[i]:
            x = target[i] - r[i]
        elif target[i] > z[i]:
            x = target[i] + r[i]
        else:
            continue
        z = np.maximum(x - r, np.minimum(x + r, z))
        hist.append(x)
    scale = max(1.0, float(np.max(np.abs(target))), float(r[-1]))
    if np.max(np.abs(z - target)) > tol * scale:
        raise NotInvertibleError(
            "initial state0 is not reachable by any input history (play outputs must satisfy "
            "|z_i - z_j| <= |r_i - r_j|), so the inverse's initial state is undefined"
        )
    return np.asarray(hist)


def _inverse_state(model: PIModel, z: Float1D, q0: float, q: Float1D) -> Float1D:
    s0 = filled(model.state0)
    if np.all(s0 == s0[0]):
        return np.full(s0.size, float(model.slopes[-1] * s0[0]))
    hist = state_history(model.thresholds, s0)
    c = float(hist[0])
    fwd = PIModel(model.p0, model.thresholds, model.weights, np.full(model.n, c))
    y_hist = fwd(hist)
    inv = PIModel(q0, z, q, np.full(model.n, float(model.slopes[-1] * c)))
    return inv.simulate(y_hist).state
