"""Identification of the Menegotto-Pinto bank (non-Masing loops): :class:`MenegottoPintoRegressor`.

Model fitted (:class:`core.nonmasing.MenegottoPintoModel` plus an output offset)::

    y(t) ≈ c + κ u + Σ_i v_i c_i(u),   κ >= ε > 0,  v_i >= 0

with the columns ``c_i = s_i`` (the smooth stop elements themselves) on clockwise loops (the
output leads: stress-strain, friction; the signed loop area,
:func:`core.fitting.orientation.loop_orientation`) and ``c_i = u - s_i`` (smooth plays) on
counter-clockwise ones. Each column rises with the input (``0 < ds_i/du <= 1``), so the
fitted model's smallest slope is ``κ >= ε``: it inverts by construction. The elements are a
fixed grid (:data:`MP_GRID`: yield levels a fraction of the training input range, a factor 2
apart, times literature shapes: Filippou's steel knee, which rounds after a plastic
excursion, and a soft Masing knee), so the model is linear in ``(c, κ, v)`` and the weights
come from bounded least squares; elements left at weight 0 are dropped. Every recording
starts from the virgin state at input 0 (the strain-from-rest start of a material test).

The same grid is the diagnosis's Menegotto-Pinto base (:mod:`core.diagnosis.bases`), so
``hyst fit --model auto`` and ``hyst diagnose`` choose among the same families
(:mod:`core.fitting.choice`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import Float1D, Float2D
from ..base import Chain
from ..exceptions import FitWarning, ParameterError, UnsupportedOptionError
from ..nonmasing import MenegottoPintoModel, oriented_bank, oriented_columns
from ..stages import Offset
from ._data import masked_range, prepare
from .boucwen import _gram, _solve
from .estimator import Estimator
from .gram import COND_LIMIT
from .orientation import loop_orientation

__all__ = ["MP_GRID", "MenegottoPintoRegressor", "grid_elements"]

#: The generic grid: yield levels as fractions of the training input range (a factor 2
#: apart) and element shapes ``(R0, cR1, cR2)``: the steel values of Filippou et al. (1983)
#: (a knee rounding with the plastic excursion, non-Masing) and a soft Masing knee
#: (``cR1 = 0``). Literature values, not fitted to any benchmark plant.
MP_GRID: dict[str, tuple] = {
    "yield": (0.025, 0.05, 0.1, 0.2, 0.4),
    "shape": ((20.0, 0.925, 0.15), (4.0, 0.0, 1.0)),
}


def grid_elements(span: float) -> tuple[Float1D, Float1D, Float1D, Float1D]:
    """``r, R0, cR1, cR2`` of the :data:`MP_GRID` elements for the input range ``span``
    (> 0, input units), each of shape ``(m,)``, shape by shape."""
    rows = [(f * span, *shape) for shape in MP_GRID["shape"] for f in MP_GRID["yield"]]
    a = np.array(rows, dtype=np.float64)
    return a[:, 0], a[:, 1], a[:, 2], a[:, 3]


def _columns(us: Sequence[Float1D], bank: MenegottoPintoModel, clockwise: bool
             ) -> list[Float2D]:
    """``s_i(u)`` (clockwise) or ``u - s_i(u)`` of each recording, from the virgin state."""
    return [oriented_columns(u, bank.element_outputs(u), clockwise) for u in us]


@dataclass(eq=False, repr=False)
class MenegottoPintoRegressor(Estimator):
    """Fit an invertible Menegotto-Pinto bank (plus output offset) on a fixed element grid.

    Parameters
    ----------
    n_operators : int, optional
        Most elements kept (the largest contributions; default: every element the bounded
        least squares leaves above 0).
    include_offset : bool
        Fit a free output offset (output units), stored in ``offset_``.
    validation : float
        Fraction at the end of every recording held out for the report when ``fit`` gets
        no ``train``/``test`` masks.
    min_slope : float, optional
        Lower bound ε of the smallest slope ``κ`` (output per input unit); default 1e-3 ×
        output range / input range.
    constraint : {"nonnegative"}
        Taken by every estimator; ``"slopes"`` raises
        :class:`~core.exceptions.UnsupportedOptionError`.
    initial_memory : {"keep"}
        Every recording starts from the virgin state at input 0.

    Attributes
    ----------
    model_ : MenegottoPintoModel
    offset_ : float
    full_model_ : Chain
        ``model_ >> Offset(offset_)``; inverse via ``full_model_.inverse()``.
    report_ : FitReport
    """

    n_operators: int | None = None
    include_offset: bool = True
    validation: float = 0.2
    min_slope: float | None = None
    constraint: str = "nonnegative"
    initial_memory: str = "keep"

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Solve the grid's weights and the offset (the work of :meth:`fit`)."""
        self._check_initial_memory()
        if self.constraint != "nonnegative":
            raise UnsupportedOptionError(
                f"a Menegotto-Pinto fit cannot use constraint={self.constraint!r}: its "
                "weights are kept invertible by a smallest slope >= min_slope; use "
                "'nonnegative'")
        n_max = self.n_operators
        if n_max is not None and (isinstance(n_max, bool) or int(n_max) != n_max
                                  or not 1 <= n_max <= 50):
            raise ParameterError(f"n_operators = {n_max!r}: the number of Menegotto-Pinto "
                                 "elements must be a whole number from 1 to 50")
        prep = prepare(u, y, train, test, validation=self.validation, min_train=40)
        eps = self._min_slope(prep)
        span = masked_range(prep.us, prep.train_masks) or masked_range(prep.us)
        self.orientation_ = loop_orientation(prep.us, prep.ys, prep.train_masks)
        cw = self.orientation_.clockwise
        r, r0, c1, c2 = grid_elements(span)
        grid = MenegottoPintoModel(1.0, r, np.zeros(r.size), r0, c1, c2)
        cols = _columns(prep.us, grid, cw)
        G, spread = _gram(prep.us, prep.ys, prep.train_masks, cols)
        theta, cond = _solve(G, spread, eps, bool(self.include_offset))
        v = theta[2:]
        contrib = v * spread[2:]
        order = np.argsort(-contrib)
        keep = order[: (r.size if n_max is None else int(n_max))]
        keep = np.sort(keep[contrib[keep] > 0]) if (contrib[keep] > 0).any() else order[:1]
        if keep.size < r.size:  # the weights once more on the elements kept
            sub = np.r_[0, 1, 2 + keep, G.shape[0] - 1]
            theta2, cond = _solve(G[np.ix_(sub, sub)], spread[sub[:-1]], eps,
                                  bool(self.include_offset))
            theta = np.r_[theta2[:2], np.zeros(r.size)]
            theta[2 + keep] = theta2[2:]
        if cond > COND_LIMIT:
            warnings.warn(f"nearly collinear Menegotto-Pinto elements (cond = {cond:.2g}): "
                          "fewer elements (n_operators) may suit this input travel",
                          FitWarning, stacklevel=3)
        self.offset_ = float(theta[0])
        self.model_ = oriented_bank(float(theta[1]), theta[2 + keep], r[keep], r0[keep],
                                    c1[keep], c2[keep], cw)
        self.full_model_ = Chain.of(self.model_, Offset(self.offset_))
        self.report_ = self._scored_report(
            prep.segments(1),
            model_type="menegotto-pinto",
            n_parameters=int(1 + self.include_offset + keep.size),
            invertible=self.model_.is_invertible,
            min_slope=self.model_.slope_bounds()[0],
            condition_number=cond,
            solver="grid-nnls",
            extra={
                "n_elements": int(keep.size),
                "min_slope_bound": eps,
                "offset": self.offset_,
                "yield_levels": self.model_.thresholds.tolist(),
                "curvature": self.model_.curvature.tolist(),
                "curvature_drop": self.model_.curvature_drop.tolist(),
                "orientation": self.orientation_.text + (
                    "; fitted with the elements themselves, y = k u + sum w_i s_i, w_i >= 0"
                    if cw else "; fitted with smooth plays, y = k u - sum v_i s_i, v_i >= 0"),
            },
        )
