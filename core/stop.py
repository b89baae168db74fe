"""The stop-operator Prandtl model (Maxwell-slip elements) and its play-type inverse.

A bank of stop operators (paper 001 eq. 4-6, the elastic-plastic element of its Fig. 3b)
gives the loops of friction and of stress-strain materials, which run **clockwise** in the
(u, y) plane (the output leads: after a reversal it moves at once, then saturates at a
friction plateau), the other way round from the play bank of :class:`core.pi.PIModel`::

    y = k u + sum_i w_i Xi_{r_i}[u],     Xi_r[u] = u - Gamma_r[u],   |Xi_r[u]| <= r

In mechanical words each term is a Maxwell-slip element: a spring of stiffness ``w_i`` in
series with a slider that slips at the force ``w_i r_i``; ``k`` is a spring in parallel.
Once every slider slips the output is ``k u`` plus the friction plateau ``±sum_i w_i r_i``.

A friction damper with a loose joint has a **backlash gap** of width ``b`` in series
(``gap``): the elements see ``v = u - x`` with the gap position ``|x| <= b / 2``. While the
force keeps its sign the joint stays closed on that side and ``v`` follows ``u``; where the
force comes down to zero (half-way through a transition between the plateaus, not at the
reversal) the joint opens and the force stays at zero while the input crosses the gap, a
dead band of width ``b`` in the input's unit, wherever the reversal was.

Since ``Xi_r = I - Gamma_r``, the model is the play-type PI ``p0 = k + sum w_i``,
``p_i = -w_i`` (:meth:`StopPIModel.equivalent_pi`, exact to round-off), so its inverse is the
play-type PI of paper 001 eq. 35-37: with ``w_i >= 0`` and ``k > 0`` every inverse weight
``q_i = w_i / (S_i S_{i+1})`` is positive (the inverse of a stop-type Prandtl operator is a
play-type one). With ``k = 0`` the output saturates at the plateau and no input gives a
larger output: :meth:`StopPIModel.inverse` says so. With a gap the inverse is that PI plus
the side of the gap the force presses on (:class:`StopGapInverse`): it crosses the gap in
one sample where the desired force changes sign.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D
from .base import Control, Field, Model, register_model
from .exceptions import NotInvertibleError, ParameterError
from .pi import PIModel
from .validation import as_finite_scalar, as_state_vector, as_vector, filled

__all__ = ["StopGapInverse", "StopPIModel"]


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
    gap : float, optional
        Width ``b >= 0`` of a backlash gap in series (input units; module docstring); 0 by
        default (no gap). With a gap the state is the sliders' positions followed by the
        bank's input ``v`` and the gap position ``x`` (``n + 2`` numbers); before the first
        sample the gap is centred and ``v`` is the sliders' mean position.

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
        Field("gap", "number", optional=True, default=0.0, doc="width of a backlash gap in "
              "series (input units): the force stays zero while the input crosses it",
              title="Backlash gap b", control=Control("b", "input", (0.0, 0.5), lower=0.0,
                                                      relative=False)),
    )
    k: float
    thresholds: Float1D
    weights: Float1D
    state0: Float1D | None = None
    gap: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "k", as_finite_scalar(self.k, "k"))
        r = as_vector(self.thresholds, "thresholds", positive=True, increasing=True)
        w = as_vector(self.weights, "weights", length=r.size)
        object.__setattr__(self, "thresholds", r)
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "state0", as_state_vector(self.state0, r.size))
        gap = as_finite_scalar(0.0 if self.gap is None else self.gap, "gap")
        if gap < 0:
            raise ParameterError(f"gap must be >= 0 (the backlash's width in input units), "
                                 f"got {gap:g}")
        object.__setattr__(self, "gap", gap)

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
        if self.gap > 0:
            s0 = filled(self.state0)
            return np.concatenate((s0, [float(np.mean(s0)), 0.0]))
        return np.array(self.state0, copy=True)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        n = self.n
        y = np.empty(u.size)
        if self.gap > 0:
            st = np.array(as_vector(state, "state", length=n + 2), copy=True)
            z, s = st[:n].copy(), st[n:].copy()
            kernels.stop_gap_output(u, self.thresholds, self.weights, self.k, 0.5 * self.gap,
                                    z, s, y, np.empty(u.size))
            return y, np.concatenate((z, s))
        z = np.array(as_vector(state, "state", length=n), copy=True)
        p0 = self.k + float(np.sum(self.weights))
        kernels.pi_output_fast(u, self.thresholds, -self.weights, p0, z, y)
        return y, z

    def stop_outputs(self, u: ArrayLike, state: ArrayLike | None = None) -> np.ndarray:
        """Each element's deflection ``Xi_{r_i}[u]``, shape ``(N, n)`` (bounded by ``r_i``)."""
        from .operators import play_bank

        uu = np.asarray(u, dtype=np.float64)
        Z = play_bank(uu, self.thresholds, self.state0 if state is None else state)[0]
        return uu[:, None] - Z

    def bank_input(self, u: ArrayLike, state: ArrayLike | None = None) -> Float1D:
        """What the elements see behind the gap, ``v = u - x``, shape ``(N,)`` (input units;
        ``u`` itself without a gap)."""
        uu = np.ascontiguousarray(u, dtype=np.float64)
        if self.gap <= 0:
            return uu.copy()
        n = self.n
        st = np.array(self.default_state() if state is None else state, dtype=np.float64)
        v = np.empty(uu.size)
        kernels.stop_gap_output(uu, self.thresholds, self.weights, self.k, 0.5 * self.gap,
                                st[:n].copy(), st[n:].copy(), np.empty(uu.size), v)
        return v

    # ------------------------------------------------------------------ inverse
    def inverse(self) -> Model:
        """The play-type PI inverse (paper 001 eq. 35-37 on :meth:`equivalent_pi`); with a
        gap, :class:`StopGapInverse` (that PI plus the gap's side).

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
            bank = self.equivalent_pi().inverse()
        except NotInvertibleError as exc:
            raise NotInvertibleError(
                "stop-pi model is not invertible: every branch slope k + w_i + ... + w_n must "
                f"be > 0 ({exc})"
            ) from None
        return StopGapInverse(bank, self.gap) if self.gap > 0 else bank


@register_model
@dataclass(frozen=True, eq=False)
class StopGapInverse(Model):
    """Inverse of a stop-operator model behind a backlash gap: ``u = G[y] + (b/2) s(y)``.

    ``G`` is the play-type PI inverse of the element bank and ``s`` the side of the gap the
    force presses on: ``sign(y)``, held while ``y`` is exactly 0 (the gap is crossed in one
    sample where the desired force changes sign).

    Parameters
    ----------
    model : PIModel
        The inverse of the element bank (output units in, input units out).
    gap : float
        The gap's width ``b > 0`` (input units).
    """

    type_name: ClassVar[str] = "stop-pi-gap-inverse"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("model", "model", doc="inverse of the element bank (a play-type PI)"),
        Field("gap", "number", doc="width of the backlash gap (input units)",
              title="Backlash gap b", control=Control("b", "input", (0.0, 0.5), lower=0.0,
                                                      relative=False)),
    )
    model: PIModel
    gap: float

    def __post_init__(self) -> None:
        if not isinstance(self.model, PIModel):
            raise ParameterError("the inverse of a stop-pi model with a gap holds a pi model")
        gap = as_finite_scalar(self.gap, "gap")
        if gap <= 0:
            raise ParameterError(f"gap must be > 0 (input units), got {gap:g}")
        object.__setattr__(self, "gap", gap)

    def default_state(self) -> Float1D:
        return np.concatenate((self.model.default_state(), [0.0]))

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        n = self.model.n
        st = as_vector(state, "state", length=n + 1)
        v, z = self.model._run(u, st[:n], dt)
        side = np.sign(u)
        if side.size:
            held = side == 0
            side[held] = np.nan
            side = np.concatenate(([st[n]], side))
            idx = np.where(np.isnan(side), 0, np.arange(side.size))
            np.maximum.accumulate(idx, out=idx)
            side = side[idx][1:]
            last = float(side[-1])
        else:
            last = float(st[n])
        return v + 0.5 * self.gap * side, np.concatenate((z, [last]))

    def inverse(self) -> StopPIModel:
        """The stop-operator model with its gap (the bank's state relaxed at zero)."""
        bank = self.model.inverse()  # a play-type PI: p0 = k + sum w, p_i = -w_i
        w = -np.asarray(bank.weights)
        return StopPIModel(float(bank.p0 + np.sum(bank.weights)), bank.thresholds, w,
                           gap=self.gap)
