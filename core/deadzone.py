"""Dead-zone superposition: the memoryless map γ of the GPI models (paper 001 eq. 41-43, 50-56).

``γ(v) = Σ_{j=-m..m} η_j S_{ρ_j}(v)`` with the dead-zone operators (eq. 42)

* ``S_ρ(v) = max(v - ρ, 0)`` for ρ > 0,
* ``S_0(v) = v``,
* ``S_ρ(v) = min(v - ρ, 0)`` for ρ < 0.

γ is continuous and piecewise linear with a kink at every ρ_j ≠ 0; the ρ_0 = 0 term is
linear over the whole line, so the two segments next to 0 share the slope η_0. The map is
memoryless (no state), so as a :class:`~core.base.Model` it has ``state = None`` and slots
anywhere into a :class:`~core.base.Chain`.

Monotonicity (corrected eq. 43). The printed condition ``Σ_{j=0..m} η_j > 0`` and
``Σ_{j=-m..-1} η_j > 0`` is a misprint: the paper's own Example 4 has
``Σ_{j=-11..-1} η_j = -4.729 < 0`` and yet an increasing γ. γ is strictly increasing (and
invertible, eq. 53-56) iff every *partial slope* is positive::

    η_0 + Σ_{g=1..j} η_g > 0   for j = 0..m      (segment [ρ_j, ρ_{j+1}])
    η_0 + Σ_{g=j..-1} η_g > 0  for j = -m..-1    (segment [ρ_{j-1}, ρ_j])

(see ``shared/notes/seed-notes.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ._typing import ArrayLike, Float1D, Float2D
from .base import Control, Field, Model, register_model
from .exceptions import NotInvertibleError, ParameterError
from .operators import dead_zone
from .validation import as_finite_scalar, as_input_signal, as_vector, frozen

__all__ = ["DeadZoneMap"]


def _segment_index(thresholds: Float1D, v: Float1D) -> np.ndarray:
    """Segment of each sample: 0 for ``v < ρ_first``, k for ``ρ_{k-1} <= v < ρ_k``, K at the end."""
    return np.searchsorted(thresholds, v, side="right")


@register_model
@dataclass(frozen=True, eq=False)
class DeadZoneMap(Model):
    """Memoryless dead-zone superposition ``w = γ(v) = Σ_j η_j S_{ρ_j}(v)`` (paper 001 eq. 41-42).

    Parameters
    ----------
    thresholds : array_like of shape (K,)
        Dead-zone thresholds ``ρ_{-m_-} < ... < ρ_{-1} < ρ_0 = 0 < ρ_1 < ... < ρ_{m_+}``
        (input units), strictly increasing and containing exactly one ``0`` (the linear
        term). The two branches may have different lengths and need not mirror each other;
        use :meth:`symmetric` for the paper's mirrored construction.
    weights : array_like of shape (K,)
        Weights ``η_j`` in the same order (output units per input unit). Any finite values
        are accepted; :attr:`is_invertible` / :meth:`inverse` check the partial slopes.

    Notes
    -----
    Evaluation is vectorised and O(N log K): each sample is placed on its linear segment
    (``np.searchsorted``) and evaluated from the segment's left breakpoint. The literal
    superposition is available as :meth:`operator_outputs` ``@ weights``.

    Examples
    --------
    >>> g = DeadZoneMap.symmetric([1.0], 2.0, [-1.0])
    >>> g([-2.0, -0.5, 0.5, 2.0]).tolist()
    [-3.0, -1.0, 1.0, 3.0]
    >>> g.inverse().thresholds.tolist(), g.inverse().weights.tolist()
    ([-2.0, 0.0, 2.0], [0.5, 0.5, 0.5])
    """

    type_name: ClassVar[str] = "deadzone"
    #: Segment indices, anchors and gathered breakpoints: 6 input-length arrays measured.
    run_arrays: ClassVar[float] = 8.0
    fields: ClassVar[tuple[Field, ...]] = (
        Field("thresholds", "numbers", doc="dead-zone thresholds (output units), with 0",
              title="Dead-zone thresholds ρ_j", increasing=True, fixed=(0.0,),
              index_zero="thresholds", control=Control("ρ{i}", "input", (-1.25, 1.25))),
        Field("weights", "numbers", doc="dead-zone weights", title="Dead-zone weights η_j",
              index_zero="thresholds", control=Control("η{i}", "output/input", (-1.0, 1.5))),
    )
    thresholds: Float1D
    weights: Float1D

    def __post_init__(self) -> None:
        rho = as_vector(self.thresholds, "deadzone thresholds (rho)", increasing=True)
        eta = as_vector(self.weights, "deadzone weights (eta)")
        if eta.size != rho.size:
            raise ParameterError(
                f"deadzone weights (eta) must have one entry per threshold: got {eta.size} "
                f"weights for {rho.size} thresholds (rho)"
            )
        zeros = np.flatnonzero(rho == 0.0)
        if zeros.size != 1:
            raise ParameterError(
                "the dead-zone thresholds ρ must hold ρ0 = 0 exactly once (the linear term, "
                f"weight η0); got {rho.tolist()}; add 0 to the thresholds"
            )
        object.__setattr__(self, "thresholds", rho)
        object.__setattr__(self, "weights", eta)

    # ------------------------------------------------------------------ construction
    @classmethod
    def symmetric(cls, rho_pos: ArrayLike, eta0: float, eta_pos: ArrayLike) -> DeadZoneMap:
        """Mirrored map of paper 001 Example 4: ``ρ_{-j} = -ρ_j``, ``η_{-j} = η_j``.

        Parameters
        ----------
        rho_pos : array_like of shape (m,)
            Positive thresholds ``0 < ρ_1 < ... < ρ_m`` (input units); may be empty.
        eta0 : float
            Weight of the linear term (slope of γ around 0).
        eta_pos : array_like of shape (m,)
            Weights ``η_1..η_m``.

        Returns
        -------
        DeadZoneMap
            With ``2m + 1`` thresholds ``(-ρ_m, ..., -ρ_1, 0, ρ_1, ..., ρ_m)``; γ is odd.
        """
        rho = as_vector(rho_pos, "rho_pos", min_length=0, positive=True, increasing=True)
        eta = as_vector(eta_pos, "eta_pos", min_length=0)
        if eta.size != rho.size:
            raise ParameterError(
                f"eta_pos must have one weight per threshold in rho_pos: got {eta.size} "
                f"weights for {rho.size} thresholds"
            )
        e0 = as_finite_scalar(eta0, "eta0")
        return cls(
            np.concatenate((-rho[::-1], [0.0], rho)),
            np.concatenate((eta[::-1], [e0], eta)),
        )

    # ------------------------------------------------------------------ properties
    @property
    def zero_index(self) -> int:
        """Position of ``ρ_0 = 0`` in :attr:`thresholds` (= number of negative thresholds)."""
        return int(np.flatnonzero(self.thresholds == 0.0)[0])

    @property
    def eta0(self) -> float:
        """Weight ``η_0`` of the linear term."""
        return float(self.weights[self.zero_index])

    @property
    def slopes(self) -> Float1D:
        """Partial slopes of γ on its ``K + 1`` segments, left to right.

        Segment ``k`` is ``(-inf, ρ_first)`` for k = 0, ``[thresholds[k-1], thresholds[k])``
        for ``0 < k < K`` and ``[ρ_last, inf)`` for k = K. On the positive side the slope on
        ``[ρ_j, ρ_{j+1}]`` is ``η_0 + η_1 + ... + η_j``; on the negative side the slope on
        ``[ρ_{j-1}, ρ_j]`` is ``η_0 + η_{-1} + ... + η_j``. The two segments next to 0 both
        have slope ``η_0``.

        Returns
        -------
        ndarray of shape (K + 1,)
            Output units per input unit.
        """
        k0 = self.zero_index
        eta = self.weights
        e0 = eta[k0]
        pos = e0 + np.cumsum(np.concatenate(([0.0], eta[k0 + 1 :])))  # segments k0+1 .. K
        neg = e0 + np.cumsum(np.concatenate(([0.0], eta[:k0][::-1])))  # segments k0 .. 0
        return frozen(np.concatenate((neg[::-1], pos)))

    @property
    def breakpoint_values(self) -> Float1D:
        """``γ(ρ_j)`` for every threshold, shape (K,), by the literal superposition (eq. 41).

        These are the inverse thresholds τ_j of eq. (53)/(55).
        """
        return frozen(self.operator_outputs(self.thresholds) @ self.weights)

    @property
    def is_invertible(self) -> bool:
        """Whether every partial slope (:attr:`slopes`) is positive (corrected eq. 43)."""
        return bool((self.slopes > 0).all())

    # ------------------------------------------------------------------ evaluation
    def operator_outputs(self, v: ArrayLike) -> Float2D:
        """Each dead-zone operator's output ``S_{ρ_j}(v)`` (eq. 42), shape ``(N, K)``.

        ``operator_outputs(v) @ weights`` is the literal superposition (41), a second
        implementation of :meth:`__call__` (memory O(N K)).
        """
        v = as_input_signal(v, "v")
        out = np.empty((v.size, self.thresholds.size))
        for j, rho in enumerate(self.thresholds):
            out[:, j] = dead_zone(v, float(rho))
        return out

    def default_state(self) -> None:
        """Memoryless: the state is always ``None``."""
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, None]:
        rho = self.thresholds
        slopes = self.slopes
        values = self.breakpoint_values
        seg = _segment_index(rho, u)
        anchor = np.maximum(seg - 1, 0)
        return values[anchor] + slopes[seg] * (u - rho[anchor]), None

    # ------------------------------------------------------------------ inverse
    def inverse(self) -> DeadZoneMap:
        """Exact inverse γ⁻¹, again a dead-zone superposition (paper 001 eq. 50-56).

        Thresholds ``τ_j = γ(ρ_j)`` (eq. 53, 55); weights ``μ_0 = 1/η_0`` and
        ``μ_j = -η_j / (s_j s_{j-1})`` with the partial slopes ``s_j`` of the branch
        (eq. 54, 56), i.e. ``μ_0 + ... + μ_j = 1 / s_j``.

        Raises
        ------
        NotInvertibleError
            If a partial slope is <= 0 (the message names it and its segment).
        """
        rho = self.thresholds
        eta = self.weights
        k0 = self.zero_index
        e0 = float(eta[k0])
        if e0 <= 0:
            raise NotInvertibleError(
                f"dead-zone map is not invertible: eta_0 = {e0:g} (the slope of gamma around "
                "0) must be > 0"
            )
        mu = np.empty_like(eta)
        mu[k0] = 1.0 / e0
        for sign, idx in ((1, np.arange(k0 + 1, rho.size)), (-1, np.arange(k0 - 1, -1, -1))):
            # idx lists the branch outwards from 0: j = 1, 2, ... (or -1, -2, ...)
            s = e0 + np.cumsum(eta[idx])
            bad = np.flatnonzero(s <= 0)
            if bad.size:
                b = int(bad[0])
                j = sign * (b + 1)
                terms = (
                    " + ".join(f"eta_{sign * k}" for k in range(1, b + 2))
                    if b < 3
                    else f"eta_{sign} + ... + eta_{j}"
                )
                inner = float(rho[idx[b]])
                outer = float(rho[idx[b + 1]]) if b + 1 < idx.size else sign * np.inf
                lo, hi = sorted((inner, outer))
                raise NotInvertibleError(
                    f"dead-zone map is not invertible: partial slope eta_0 + {terms} "
                    f"= {s[b]:g} on the segment [{lo:g}, {hi:g}] must be > 0 (gamma must "
                    "be strictly increasing; corrected eq. 43); make the weights beyond that "
                    "threshold less negative"
                )
            s_prev = np.concatenate(([e0], s[:-1]))
            mu[idx] = -eta[idx] / (s * s_prev)
        tau = np.array(self.breakpoint_values, copy=True)
        tau[k0] = 0.0
        return DeadZoneMap(tau, mu)

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type_name,
            "thresholds": self.thresholds.tolist(),
            "weights": self.weights.tolist(),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> DeadZoneMap:
        missing = [k for k in ("thresholds", "weights") if k not in d]
        if missing:
            raise ParameterError(f"deadzone model is missing field(s): {', '.join(missing)}")
        return cls(d["thresholds"], d["weights"])
