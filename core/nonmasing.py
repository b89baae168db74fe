"""A bank of smooth stop elements with the Menegotto-Pinto transition: non-Masing loops.

The stop (Maxwell-slip) bank of :mod:`core.stop` has branches that are scaled copies of
its first loading curve (Masing's rule). Stress-strain materials such as steel do not: the
knee of a branch after a large plastic excursion is rounder than after a small one
(Bauschinger effect). This model keeps the stop bank's structure and gives each element the
transition of Menegotto and Pinto (1973) with the excursion-dependent curvature of
Filippou, Popov and Bertero (1983)::

    y = k u + sum_i w_i s_i[u]

Element ``s_i`` has unit modulus and the yield level ``r_i`` (input units; also its output
bound, ``|s_i| < r_i``) and no hardening of its own (``k`` carries it). A branch starts at
the reversal point ``(u_r, s_r)`` where the input's direction ``d`` changes and runs
towards the target ``(u_a, d r_i)`` where the unit line from the reversal meets the new
direction's plateau (``u_a = u_r + d r_i - s_r``)::

    s* = e* / (1 + |e*|^R)^(1/R),   e* = (u - u_r) / (u_a - u_r),   s* = (s - s_r) / (u_a - u_r)

with the curvature ``R = R0 (1 - cR1 xi / (cR2 + xi))`` and ``xi = |u_m - u_a| / r_i``,
``u_m`` the largest input reached at a reversal so far in the new direction (``±r_i``
before any excursion): the first loading from rest has ``R = R0``. With ``cR1 = 0`` every
branch is the doubled first loading curve (Masing's rule); with ``R0`` large the element is
the exact stop operator ``Xi_r`` (the knee error is ``ln 2 / R0`` of ``r``).

Orientation: with weights ``w_i >= 0`` the loops run **clockwise** in the (u, y) plane (the
output leads after a reversal), as the stop bank's; the counter-clockwise form (the smooth
play ``u - s_i`` with weight ``p_i >= 0``, as in a piezo's PI) is the same model with
``k = p0 + sum p_i`` and ``w_i = -p_i``. One model, weights of either sign, as
:class:`core.stop.StopPIModel` and its :meth:`~core.stop.StopPIModel.equivalent_pi`.

Every branch's slope ``dy/du = k + sum_i w_i f_i`` with ``f_i = (1 + |e*|^R)^(-1 - 1/R)``
in ``(0, 1]``, so it lies between ``k + sum_i min(w_i, 0)`` and ``k + sum_i max(w_i, 0)``;
when the first is positive the output rises strictly with the input and
:class:`MenegottoPintoInverse` solves it sample by sample.

The reference implementation this model is checked against is the benchmark's
stress-strain law (``benchmarks/diagnosis/families.MenegottoPinto``): one element with
``k = b``, ``w = 1 - b`` and ``r = eps_y`` gives its stress over ``E0``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from . import kernels
from ._typing import ArrayLike, Float1D
from .base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from .exceptions import NotInvertibleError, ParameterError
from .validation import as_finite_scalar, as_input_signal, as_vector

__all__ = ["MAX_CURVATURE", "MenegottoPintoInverse", "MenegottoPintoModel", "oriented_bank",
           "oriented_columns", "state_size"]

#: Largest curvature ``R0`` accepted (a knee within ``ln 2 / R0`` of a sharp corner: 7e-7 of
#: the yield level; larger values only add round-off).
MAX_CURVATURE = 1e6
#: Output evaluations per sample priced for the inverse's solve.
_PRICED_SOLVES = 30.0
#: Work units of one element's update (a power and a division, more at a reversal).
_ELEMENT_WORK = 24.0


def oriented_columns(u: Float1D, elements: np.ndarray, clockwise: bool) -> np.ndarray:
    """The columns a bank is fitted on in its loops' orientation, shape ``(N, n)``: the
    elements' outputs ``s_i(u)`` (``elements``, :meth:`MenegottoPintoModel.element_outputs`)
    for clockwise loops, the smooth plays ``u - s_i(u)`` for counter-clockwise ones, so that
    weights ``>= 0`` on them give an invertible bank (:func:`oriented_bank`)."""
    return elements if clockwise else np.asarray(u, dtype=np.float64)[:, None] - elements


def oriented_bank(k: float, v: Float1D, thresholds: Float1D, curvature: Float1D,
                  curvature_drop: Float1D, curvature_scale: Float1D, clockwise: bool,
                  history: Float1D | None = None) -> MenegottoPintoModel:
    """The bank of slope ``k`` and weights ``v`` on :func:`oriented_columns` (``k u + sum
    v_i c_i``): clockwise ``k`` and ``w = v``; counter-clockwise ``k + sum v`` and
    ``w = -v`` (``u - s_i``: a smooth play), other parameters as
    :class:`MenegottoPintoModel`'s."""
    vv = np.asarray(v, dtype=np.float64)
    return MenegottoPintoModel(float(k) if clockwise else float(k + vv.sum()), thresholds,
                               vv if clockwise else -vv, curvature, curvature_drop,
                               curvature_scale, history=history)


def state_size(n: int) -> int:
    """Length of the state vector of a bank of ``n`` elements: ``3 + 5 n`` (the last input,
    the direction, the input at the last reversal, then per element its output, its output
    at the last reversal, the largest and the smallest input at a reversal so far and its
    branch's curvature)."""
    return 3 + 5 * int(n)


@register_model
@dataclass(frozen=True, eq=False)
class MenegottoPintoModel(Model):
    """Bank of Menegotto-Pinto smooth stop elements ``y = k u + sum_i w_i s_i[u]``.

    Parameters
    ----------
    k : float
        Slope once every element has yielded (output per input unit): the hardening.
        ``k > 0`` (with ``w_i >= 0``) for an invertible model.
    thresholds : array_like of shape (n,)
        Yield levels ``r_i > 0`` of the elements (input units): the deflection at which an
        element's knee lies (any order; several elements may share one).
    weights : array_like of shape (n,)
        Element moduli ``w_i`` (output per input unit); ``w_i >= 0`` gives clockwise loops,
        ``w_i <= 0`` counter-clockwise ones (module docstring).
    curvature : array_like of shape (n,)
        ``R0`` of each element, ``0 < R0 <= 1e6`` (large: a sharp knee, the stop operator).
    curvature_drop : array_like of shape (n,)
        ``cR1`` of each element, ``0 <= cR1 < 1``: how much the knee rounds after a large
        plastic excursion (0: Masing's rule).
    curvature_scale : array_like of shape (n,)
        ``cR2 > 0`` of each element: the excursion (in yield levels) at which half of that
        rounding is reached.
    history : array_like of shape (m,), optional
        A virtual input history (input units) run from the virgin state at input 0 before
        the first sample: the memory the record starts with (none by default).

    Notes
    -----
    The state (``Response.state``) is a vector of :func:`state_size` numbers; the default
    is the state the ``history`` leaves from the virgin state at input 0 (every element at
    0, no branch yet).

    Examples
    --------
    >>> m = MenegottoPintoModel(0.1, [1.0], [1.0], [20.0], [0.0], [0.15])
    >>> y = m([0.0, 1.0, 3.0, 0.0])
    >>> round(float(y[2]), 3)  # yielded: 0.1 * 3 + the plateau 1
    1.3
    """

    type_name: ClassVar[str] = "menegotto-pinto"
    estimator: ClassVar[str | None] = "core.fitting:MenegottoPintoRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("k", "number", doc="slope once every element has yielded (output/input)",
              title="Hardening slope k", scale_with=("weights",),
              control=Control("k", "output/input", (-0.5, 1.5))),
        Field("thresholds", "numbers", doc="yield level r_i of each element (input units)",
              title="Yield levels r_i",
              control=Control("r{i}", "input", (0.0, 1.25), lower=0.0, strict=True)),
        Field("weights", "numbers", doc="element moduli w_i (output/input); >= 0: clockwise "
              "loops", title="Element moduli w_i", scale_with=("k",),
              control=Control("w{i}", "output/input", (-1.5, 1.5))),
        Field("curvature", "numbers", doc="transition curvature R0 of each element (large: "
              "a sharp knee)", title="Curvatures R0_i",
              control=Control("R0{i}", "1", (1.0, 40.0), step=0.1, relative=False,
                              lower=0.0, upper=MAX_CURVATURE, strict=True)),
        Field("curvature_drop", "numbers", doc="rounding of the knee after a plastic "
              "excursion, 0 (Masing) to < 1", title="Curvature drops cR1_i",
              control=Control("cR1{i}", "1", (0.0, 0.99), step=0.01, relative=False,
                              lower=0.0, upper=0.99)),
        Field("curvature_scale", "numbers", doc="excursion (in yield levels) giving half "
              "the drop, > 0", title="Curvature scales cR2_i",
              control=Control("cR2{i}", "1", (0.01, 2.0), step=0.01, relative=False,
                              lower=0.0, strict=True)),
        Field("history", "numbers", optional=True, doc="virtual input history before the "
              "first sample, run from rest at 0 (input units)", title="Input history u_k",
              control=Control("u{i}", "input", (-1.25, 1.25))),
    )
    k: float
    thresholds: Float1D
    weights: Float1D
    curvature: Float1D
    curvature_drop: Float1D
    curvature_scale: Float1D
    history: Float1D | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "k", as_finite_scalar(self.k, "k"))
        r = as_vector(self.thresholds, "thresholds", positive=True)
        n = r.size
        w = as_vector(self.weights, "weights", length=n)
        r0 = as_vector(self.curvature, "curvature", length=n, positive=True)
        c1 = as_vector(self.curvature_drop, "curvature_drop", length=n, nonnegative=True)
        c2 = as_vector(self.curvature_scale, "curvature_scale", length=n, positive=True)
        if (r0 > MAX_CURVATURE).any():
            j = int(np.flatnonzero(r0 > MAX_CURVATURE)[0])
            raise ParameterError(f"curvature[{j}] = {r0[j]:g} must be <= {MAX_CURVATURE:g} "
                                 "(a larger one is a sharp corner to round-off)")
        if (c1 >= 1.0).any():
            j = int(np.flatnonzero(c1 >= 1.0)[0])
            raise ParameterError(f"curvature_drop[{j}] = {c1[j]:g} must be < 1 (the curvature "
                                 "R0 (1 - cR1 xi / (cR2 + xi)) must stay positive)")
        for name, v in (("thresholds", r), ("weights", w), ("curvature", r0),
                        ("curvature_drop", c1), ("curvature_scale", c2)):
            object.__setattr__(self, name, v)
        if self.history is not None:
            h = as_vector(self.history, "history", min_length=0)
            object.__setattr__(self, "history", h if h.size else None)

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of elements."""
        return int(self.thresholds.size)

    @property
    def plateau(self) -> float:
        """``sum_i w_i r_i`` (output units): what the elements carry once all have yielded,
        on top of ``k u``."""
        return float(np.dot(self.weights, self.thresholds))

    def slope_bounds(self) -> tuple[float, float]:
        """Smallest and largest branch slope ``dy/du``: ``k + sum_i min(w_i, 0)`` and
        ``k + sum_i max(w_i, 0)`` (the first is approached, never reached, where
        ``w_i > 0``)."""
        w = self.weights
        return (float(self.k + np.sum(np.minimum(w, 0.0))),
                float(self.k + np.sum(np.maximum(w, 0.0))))

    @property
    def is_invertible(self) -> bool:
        """Whether the output rises strictly with the input on every branch."""
        return self.slope_bounds()[0] > 0

    # ------------------------------------------------------------------ simulation
    def virgin_state(self) -> Float1D:
        """The virgin state at input 0: every element at 0, no branch yet, excursions
        ``±r_i`` (shape ``(3 + 5 n,)``, :func:`state_size`)."""
        st = np.zeros(state_size(self.n))
        body = st[3:].reshape(self.n, 5)
        body[:, 2] = self.thresholds
        body[:, 3] = -self.thresholds
        body[:, 4] = self.curvature
        return st

    def default_state(self) -> Float1D:
        """The state the :attr:`history` leaves from :meth:`virgin_state` (that state
        without one), shape ``(3 + 5 n,)``."""
        st = self.virgin_state()
        if self.history is not None:
            kernels.mp_output(np.ascontiguousarray(self.history), *self._args(), st,
                              np.empty(self.history.size))
        return st

    def _state(self, state: Any) -> Float1D:
        st = np.array(as_vector(state, "state", length=state_size(self.n)), dtype=np.float64,
                      copy=True)
        d = st[1]
        if d not in (-1.0, 0.0, 1.0):
            raise ParameterError(f"state[1] (the branch direction) must be -1, 0 or 1, got "
                                 f"{d:g}")
        el = st[3:].reshape(self.n, 5)
        if not np.all(np.isfinite(st)):
            raise ParameterError("the state must hold finite numbers only")
        bad = np.flatnonzero(~(el[:, 4] > 0.0) | (np.abs(el[:, 0]) > self.thresholds))
        if bad.size:
            i = int(bad[0])
            raise ParameterError(
                f"state of element {i}: its curvature (entry {3 + 5 * i + 4}) must be > 0 and "
                f"its output (entry {3 + 5 * i}) at most its yield level {self.thresholds[i]:g} "
                f"in size, got {el[i, 4]:g} and {el[i, 0]:g}")
        return st

    def _args(self) -> tuple[Any, ...]:
        return (self.thresholds, self.weights, self.k, self.curvature, self.curvature_drop,
                self.curvature_scale)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        st = self._state(state)
        y = np.empty(u.size)
        kernels.mp_output(u, *self._args(), st, y)
        return y, st

    def element_outputs(self, u: ArrayLike, state: ArrayLike | None = None) -> np.ndarray:
        """Each element's output ``s_i[u]``, shape ``(N, n)`` (input units, ``|s_i| < r_i``),
        from ``state`` (:meth:`default_state` by default)."""
        uu = as_input_signal(u)
        st = self._state(self.default_state() if state is None else state)
        r, c0, c1, c2 = (self.thresholds, self.curvature, self.curvature_drop,
                         self.curvature_scale)
        out = np.empty((uu.size, self.n))
        kernels.mp_elements(np.ascontiguousarray(uu, dtype=np.float64), r, c0, c1, c2, st,
                            out)
        return out

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Elements x samples (a power per element update); work in element operations,
        memory in bytes."""
        n, m = float(samples), float(self.n)
        return RunCost(n * (1.0 + m * _ELEMENT_WORK),
                       SAMPLE_BYTES * (self.run_arrays * n + 5.0 * m))

    # ------------------------------------------------------------------ inverse
    def check_invertible(self) -> None:
        """Raise ``NotInvertibleError`` with the reason when a branch can be flat or fall."""
        lo, _ = self.slope_bounds()
        if lo > 0:
            return
        if (self.weights >= 0).all():
            raise NotInvertibleError(
                f"menegotto-pinto model is not invertible: k = {self.k:g} must be > 0; once "
                f"every element has yielded the output is k u plus the plateau "
                f"{self.plateau:g}, so without a positive k no input gives a larger output"
            )
        raise NotInvertibleError(
            f"menegotto-pinto model is not invertible: its smallest branch slope, k plus the "
            f"negative element moduli, is {lo:g}; it must be > 0, or the output falls while "
            f"the input rises on some branch (raise k or shrink the negative moduli)"
        )

    def inverse(self) -> MenegottoPintoInverse:
        """The compensator: the input whose output is the desired one, sample by sample.

        Raises
        ------
        NotInvertibleError
            If a branch slope can be zero or negative (the message says which rule).
        """
        return MenegottoPintoInverse(self)


@register_model
@dataclass(frozen=True, eq=False)
class MenegottoPintoInverse(Model):
    """Inverse of a :class:`MenegottoPintoModel`, solved sample by sample.

    From the forward state the output is a continuous, strictly increasing function of the
    next input with slope in :meth:`MenegottoPintoModel.slope_bounds`; the input is bracketed
    from those slopes and found by regula falsi (Illinois, a bisection every fourth step) to
    adjacent doubles, then the elements advance to it. The state is the forward model's
    (:func:`state_size` numbers), so ``model(inverse(y)) == y`` to the solve's round-off.

    Parameters
    ----------
    model : MenegottoPintoModel
        The invertible forward model.
    """

    type_name: ClassVar[str] = "menegotto-pinto-inverse"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("model", "model", doc="the Menegotto-Pinto bank being inverted"),
    )
    model: MenegottoPintoModel

    def __post_init__(self) -> None:
        if not isinstance(self.model, MenegottoPintoModel):
            raise ParameterError(f"menegotto-pinto-inverse.model must be a 'menegotto-pinto' "
                                 f"model, got {type(self.model).__name__}")
        self.model.check_invertible()

    def default_state(self) -> Float1D:
        return self.model.default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Float1D]:
        m = self.model
        st = m._state(state)
        lo, hi = m.slope_bounds()
        out = np.empty(u.size)
        kernels.mp_inverse(u, *m._args(), lo, hi, st, np.empty(st.size), out)
        return out, st

    def inverse(self) -> MenegottoPintoModel:
        """The forward model."""
        return self.model

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """The forward run's work times the output evaluations of the solve (work in element
        operations, memory in bytes)."""
        f = self.model.cost(samples, dt)
        return RunCost(_PRICED_SOLVES * f.work, f.memory)
