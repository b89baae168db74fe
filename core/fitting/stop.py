"""Identification of the stop-operator Prandtl model (Maxwell-slip): :class:`StopPIRegressor`.

Model fitted (:class:`core.stop.StopPIModel` plus an output offset)::

    y(t) ≈ c + k u(t) + Σ_i w_i Ξ_{r_i}[u](t),    k >= ε > 0,  w_i >= 0   ("nonnegative")

the clockwise loops of friction and stress-strain data. It is the PI estimator
(:class:`~core.fitting.pi.PIRegressor`: thresholds by rule, ``n`` by blocked
cross-validation, weights by NNLS on the streamed Gram matrix, the initial-memory rules)
with the stop change of variables of :func:`core.fitting.pi.constraint_transform`
(``p0 = k + Σ w_i``, ``p_i = -w_i``). ``constraint="slopes"`` only bounds every branch
slope ``k + w_i + ... + w_n`` below by ε: weights of either sign, so a branch may rise,
flatten and rise again (a dead band after every reversal, as a backlash gives).

The report names the physics of the fitted branch (:func:`branch_features`): the friction
plateau (the output carried once every element slips, output units) and, when the branch
has a flat stretch between two rises, that dead band's width (input units).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import Float1D
from ..stop import StopPIModel
from .orientation import LoopOrientation
from .pi import PIRegressor

__all__ = ["DEAD_BAND_SLOPE", "BranchFeatures", "StopPIRegressor", "branch_features"]

#: A stretch of a branch counts as a dead band where its slope stays below this share of the
#: branch's mean slope over the travel it takes to make 95 % of its rise (on the friction
#: damper at 1 Hz, 30 lb: the fitted branch rises to half its height in 0.07 in, stays
#: below this share for 0.09-0.14 in, then rises again: the measured branches reach 40 % of
#: their rise 0.05 in after a reversal and 60 % only 0.23 in after it).
DEAD_BAND_SLOPE = 0.3
#: Share of the branch's rise that defines the travel of the mean slope above.
RISE_SHARE = 0.95


@dataclass(frozen=True)
class BranchFeatures:
    """What a fitted stop-operator branch shows, in physical units.

    Attributes
    ----------
    plateau : float
        The friction plateau ``Σ w_i r_i`` (output units): half the output's jump between
        the two branches once every element slips (on top of the spring ``k u``).
    slip_travel : float
        Input travel after a reversal until every element slips, ``2 r_n`` (input units).
    dead_band : float
        Width (input units) of the longest flat stretch of the branch (slope below
        :data:`DEAD_BAND_SLOPE` x its mean slope over the travel of 95 % of its rise) that
        has a rise on both sides: the dead band after every reversal; 0 without one.
    dead_band_start : float
        Input travel after a reversal where that dead band starts (input units).
    dead_band_level : float
        Share (0..1) of the branch's rise reached before the dead band.
    concave : bool
        Every element weight is non-negative: the branch's slope only falls, so no dead band
        can show (a fit with ``constraint="slopes"`` lets it flatten and rise again).
    """

    plateau: float
    slip_travel: float
    dead_band: float
    dead_band_start: float
    dead_band_level: float
    concave: bool = False

    def text(self, input_unit: str = "input units", output_unit: str = "output units") -> str:
        """The features in words."""
        out = (f"friction plateau {self.plateau:.4g} {output_unit} (reached "
               f"{self.slip_travel:.4g} {input_unit} after a reversal)")
        if self.dead_band > 0:
            out += (f"; dead band (backlash) {self.dead_band:.4g} {input_unit} wide, "
                    f"starting {self.dead_band_start:.4g} {input_unit} after every reversal, "
                    f"at {self.dead_band_level:.0%} of the branch's rise")
        elif self.concave:
            out += ("; a dead band after the reversals cannot show with non-negative element "
                    "weights (fit with --constraint slopes to let the branch flatten and rise "
                    "again)")
        else:
            out += "; no dead band after the reversals"
        return out


def branch_features(model: StopPIModel) -> BranchFeatures:
    """The plateau and the dead band of ``model``'s branch (:class:`BranchFeatures`).

    A branch after a reversal rises by ``2 φ(Δu / 2)`` over the travel ``Δu`` (Masing's
    rule, the loading curve ``φ``), piecewise linear with slope ``S_i`` while
    ``2 r_{i-1} < Δu < 2 r_i``.
    """
    r = model.thresholds
    S = model.slopes  # S[0] before the first element slips ... S[n] = k
    edges = np.concatenate(([0.0], 2.0 * r))
    widths = np.diff(edges)
    rise = float(np.sum(S[:-1] * widths))
    travel = float(edges[-1])
    plateau = model.friction_plateau
    concave = bool((model.weights >= 0).all())
    if rise <= 0 or travel <= 0:
        return BranchFeatures(plateau, travel, 0.0, 0.0, 0.0, concave)
    cum = np.cumsum(S[:-1] * widths)
    n = int(np.searchsorted(cum, RISE_SHARE * rise)) + 1  # segments up to 95 % of the rise
    n = min(n, widths.size)
    flat = S[:-1] < DEAD_BAND_SLOPE * RISE_SHARE * rise / float(edges[n])
    best = (0.0, 0.0, 0.0)
    i = 0
    while i < n:
        if not flat[i]:
            i += 1
            continue
        j = i
        while j < n and flat[j]:
            j += 1
        before = float(np.sum(S[:i] * widths[:i]))
        after = float(np.sum(S[j:n] * widths[j:n]))
        w = float(np.sum(widths[i:j]))
        # a dead band has a real rise on both sides (not the saturation at the end)
        if before > 0.05 * rise and after > 0.05 * rise and w > best[0]:
            best = (w, float(edges[i]), before / rise)
        i = j
    return BranchFeatures(plateau, travel, *best, concave=concave)


class StopPIRegressor(PIRegressor):
    """Fit a stop-operator Prandtl model (Maxwell-slip elements) plus output offset.

    The parameters and the fit are those of :class:`~core.fitting.pi.PIRegressor`
    (``n_operators`` by cross-validation, threshold rule, ``initial_memory``, ...), with
    stop operators: ``constraint="nonnegative"`` (default) fits ``k >= ε`` and ``w_i >= 0``
    (concave branches: Coulomb-like friction, elastic-plastic materials);
    ``"slopes"`` every branch slope ``>= ε`` (weights of either sign: a flat dead band
    between two rises). The orientation of the data is measured and reported; on
    counter-clockwise data the stop model (which has clockwise loops) fits badly, and the
    report's orientation line says why.

    Attributes
    ----------
    model_ : StopPIModel
        Fitted model (without offset), relaxed at the first training recording's first
        input sample.
    full_model_ : Chain
        ``model_ >> Offset(offset_)``: its inverse is a play-type PI (paper 001 eq. 35-37).
    features_ : BranchFeatures
        The friction plateau and the dead band of the fitted branch.
    (others as :class:`~core.fitting.pi.PIRegressor`)
    """

    def _constraint_for(self, orientation: LoopOrientation) -> str:
        if self.constraint == "nonnegative":
            return "stop"
        return super()._constraint_for(orientation)

    def _build(self, p0: float, r: Float1D, w: Float1D, u0: float) -> StopPIModel:
        k = float(p0 + np.sum(w))
        return StopPIModel(k, r, -np.asarray(w), np.full(r.size, u0))

    def _extra(self) -> dict[str, Any]:
        self.features_ = branch_features(self.model_)
        f = self.features_
        return {"friction_plateau": f.plateau, "slip_travel": f.slip_travel,
                "dead_band": f.dead_band, "dead_band_start": f.dead_band_start,
                "branch": f.text()}

    # the weights in the report are the stop form's
    @property
    def stiffness_(self) -> float:
        """``k`` of the fitted model (output per input unit)."""
        return float(self.model_.k)
