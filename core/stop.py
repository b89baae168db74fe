"""The stop-operator Prandtl model (Maxwell-slip elements) and its play-type inverse.

A bank of stop operators (paper 001 eq. 4-6, the elastic-plastic element of its Fig. 3b)
gives the loops of friction and of stress-strain materials, which run **clockwise** in the
(u, y) plane (the output leads: after a reversal it moves at once, then saturates at a
friction plateau), the other way round from the play bank of :class:`core.pi.PIModel`::

    y = k u + sum_i w_i Xi_{r_i}[u],     Xi_r[u] = u - Gamma_r[u],   |Xi_r[u]| <= r

In mechanical words each term is a Maxwell-slip element: a spring of stiffness ``w_i`` in
series with a slider that slips at the force ``w_i r_i``; ``k`` is a spring in parallel.
Once every slider slips the output is ``k u`` plus the friction plateau ``±sum_i w_i r_i``.

Since ``Xi_r = I - Gamma_r``, the model is the play-type PI ``p0 = k + sum w_i``,
``p_i = -w_i`` (:meth:`StopPIModel.equivalent_pi`, exact to round-off), so its inverse is the
play-type PI of paper 001 eq. 35-37: with ``w_i >= 0`` and ``k > 0`` every inverse weight
``q_i = w_i / (S_i S_{i+1})`` is positive (the inverse of a stop-type Prandtl operator is a
play-type one). With ``k = 0`` the output saturates at the plateau and no input gives a
larger output: :meth:`StopPIModel.inverse` says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D
from .base import Control, Field, Model, register_model
from .exceptions import NotInvertibleError
from .pi import PIModel
from .validation import as_finite_scalar, as_state_vector, as_vector

__all__ = ["StopPIModel"]


@register_model
@dataclass(frozen=True, eq=False)
class StopPIModel(Model):
    """Stop-operator Prandtl model (Maxwell-slip) ``y = k u + sum_i w_i Xi_{r_i}[u]``.

    Parameters
    ----------
    k : float
        Stiffness of the parallel spring (output per input unit): the slope once every
        element slips; ``k > 0`` for an invertible model.
    thresholds : array_like of shape (n,)
        Stop thresholds ``0 < r_1 < ... < r_n`` (input units): the deflection at which
        element ``i`` slips.
    weights : array_like of shape (n,)
        Element stiffnesses ``w_i`` (output per input unit); element ``i`` slips at the
        force ``w_i r_i``. Negative weights are allowed (a branch with a flat stretch, such
        as a dead band, needs them) as long as every branch slope stays positive for the
        inverse (:meth:`inverse` checks).
    state0 : array_like of shape (n,), optional
        Slider positions before the first sample (input units; element ``i``'s deflection
        is ``u - state0[i]``); zeros by default. A scalar is broadcast.

    Examples
    --------
    >>> m = StopPIModel(0.1, [0.5, 1.0], [1.0, 0.5])
    >>> m.friction_plateau
    1.0
    >>> m.equivalent_pi().weights.tolist()
    [-1.0, -0.5]
    """

    type_name: ClassVar[str] = "stop-pi"
    estimator: ClassVar[str | None] = "core.fitting:StopPIRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("k", "number", doc="stiffness of the parallel spring (output/input), the slope "
              "once every element slips", title="Parallel stiffness k",
              control=Control("k", "output/input", (-0.5, 1.5)), scale_with=("weights",)),
        Field("thresholds", "numbers", doc="stop thresholds r_i (input units): the deflection "
              "at which each element slips, increasing", title="Slip deflections r_i",
              increasing=True,
              control=Control("r{i}", "input", (0.0, 1.25), lower=0.0, strict=True)),
        Field("weights", "numbers", doc="element stiffnesses w_i (output/input); element i "
              "slips at the force w_i r_i", title="Element stiffnesses w_i",
              control=Control("w{i}", "output/input", (-0.5, 1.5)), scale_with=("k",)),
        Field("state0", "numbers", optional=True, doc="slider positions before the first "
              "sample (input units)", title="Initial slider positions x_i(0)",
              scale_with=("thresholds",), control=Control("x{i}(0)", "input", (-1.25, 1.25))),
    )
    k: float
    thresholds: Float1D
    weights: Float1D
    state0: Float1D | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "k", as_finite_scalar(self.k, "k"))
        r = as_vector(self.thresholds, "thresholds", positive=True, increasing=True)
        w = as_vector(self.weights, "weights", length=r.size)
        object.__setattr__(self, "thresholds", r)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "state0", as_state_vector(self.state0, r.size))

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of stop operators (Maxwell-slip elements)."""
        return int(self.thresholds.size)

    @property
    def friction_plateau(self) -> float:
        """``sum_i w_i r_i`` (output units): what the elements carry once all slip, on top of
        the spring ``k u`` (a Coulomb friction force for a damper)."""
        return float(np.dot(self.weights, self.thresholds))

    @property
    def slip_forces(self) -> Float1D:
        """``w_i r_i`` of each element (output units), shape ``(n,)``."""
        return self.weights * self.thresholds

    @property
    def slopes(self) -> Float1D:
        """Branch slopes after a reversal, shape ``(n+1,)``: ``k + sum_{j>=i} w_j`` before
        element ``i`` slips, down to ``k`` once all slip."""
        return self.equivalent_pi().slopes

    @property
    def is_invertible(self) -> bool:
        """Whether every branch slope (the last one is ``k``) is positive."""
        return bool((self.slopes > 0).all())

    def equivalent_pi(self) -> PIModel:
        """The same operator as a play-type PI: ``p0 = k + sum w_i``, ``p_i = -w_i``, the same
        thresholds and state (``Xi_r = I - Gamma_r``)."""
        return PIModel(self.k + float(np.sum(self.weights)), self.thresholds, -self.weights,
                       self.state0)

    def loading_curve(self, r: ArrayLike) -> Float1D:
        """Initial loading curve ``k r + sum_i w_i min(r, r_i)`` (odd in ``r``), shape
        ``(M,)`` for ``r`` of shape ``(M,)`` (input travel from the virgin state)."""
        return self.equivalent_pi().loading_curve(r)

    # ------------------------------------------------------------------ simulation
    def default_state(self) -> Float1D:
        return np.array(self.state0, copy=True)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        z = np.array(as_vector(state, "state", length=self.n), copy=True)
        y = np.empty(u.size)
        p0 = self.k + float(np.sum(self.weights))
        kernels.pi_output_fast(u, self.thresholds, -self.weights, p0, z, y)
        return y, z

    def stop_outputs(self, u: ArrayLike, state: ArrayLike | None = None) -> np.ndarray:
        """Each element's deflection ``Xi_{r_i}[u]``, shape ``(N, n)`` (bounded by ``r_i``)."""
        from .operators import play_bank

        uu = np.asarray(u, dtype=np.float64)
        Z = play_bank(uu, self.thresholds, self.state0 if state is None else state)[0]
        return uu[:, None] - Z

    # ------------------------------------------------------------------ inverse
    def inverse(self) -> PIModel:
        """The play-type PI inverse (paper 001 eq. 35-37 on :meth:`equivalent_pi`).

        Raises
        ------
        NotInvertibleError
            With ``k <= 0`` (the output saturates at the friction plateau: no input gives
            more) or a non-positive branch slope.
        """
        if self.k <= 0:
            raise NotInvertibleError(
                f"stop-pi model is not invertible: k = {self.k:g} must be > 0; without a "
                f"parallel spring the output saturates at the friction plateau "
                f"{self.friction_plateau:g}, so no input gives a larger output"
            )
        try:
            return self.equivalent_pi().inverse()
        except NotInvertibleError as exc:
            raise NotInvertibleError(
                "stop-pi model is not invertible: every branch slope k + w_i + ... + w_n must "
                f"be > 0 ({exc})"
            ) from None
