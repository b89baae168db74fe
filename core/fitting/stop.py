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

**Backlash gap** (``gap="auto"``, the default): a loose joint in series
(:attr:`core.stop.StopPIModel.gap`) holds the force at zero while the input crosses it,
half-way through every transition wherever the reversal was; a dead band at a fixed travel
after the reversal (the free-sign branch above) can follow it only when every reversal is
at the same level. The gap is fitted by alternation: the elements' input behind the gap
``v = u - x`` is simulated with the current model and the weights are refitted on ``v``
(until ``v`` stops moving, at most :data:`GAP_ITERATIONS` times) for each width of
:data:`GAP_GRID` (shares of the input's range), refined by :data:`GAP_REFINE`
golden-section steps; the best width replaces the fit without a gap when it lowers the
training rows' MSE by :data:`GAP_MIN_GAIN` (the held-out rows are never looked at). On
counter-clockwise loops no gap is tried. On the
friction damper (30 lb) the chosen gap is 0.13-0.14 in at 0.25, 1 and 2 Hz, the width of the
shelf at zero force in its loops.

**Slip force by direction** (``signed=True``, the default; tried with the gap search, on
clockwise loops): the bank's output ``z`` is followed by a gain that depends on its sign
(:class:`core.stages.SignedGain`: ``g+ z`` for ``z >= 0``, ``g- z`` below), so the plateau
while the force is negative is ``g- / g+`` times the one while it is positive and the force
stays zero in the gap. ``c, g+, g-`` are fitted by least squares on ``z`` and the bank is
refitted (without an offset) on the output mapped back, :data:`SIGNED_ITERATIONS` times, on
the training rows only; tried only when two gains on the first bank lower the training MSE
of one gain by :data:`SIGNED_MIN_GAIN` (a symmetric loop costs nothing more), and kept when
the result lowers the training MSE of the symmetric fit by that share.
``g+`` is folded into the bank, so the saved model is ``bank >> SignedGain(1, ratio) >>
Offset``. On the friction damper at 36 lb the ratio is 1.64 (plateaus 2.73 and 4.48 kip)
and the held-out error falls from 6.81 to 3.13 % of range; at 30 lb two gains lower the
training MSE of one by 0-6 % only and the fit is left symmetric.
"""

from __future__ import annotations

import dataclasses
import inspect
import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._typing import Float1D
from ..base import Chain
from ..exceptions import ParameterError
from ..stages import Offset, SignedGain
from ..stop import StopPIModel
from ..warning_filters import FILTERS
from ._data import prepare, unpack_recordings
from .metrics import evaluate_fit
from .orientation import LoopOrientation
from .pi import PIRegressor

__all__ = ["DEAD_BAND_SLOPE", "GAP_GRID", "GAP_MIN_GAIN", "SIGNED_MIN_GAIN", "BranchFeatures",
           "StopPIRegressor", "branch_features"]

#: A stretch of a branch counts as a dead band where its slope stays below this share of the
#: branch's mean slope over the travel it takes to make 95 % of its rise (on the friction
#: damper at 1 Hz, 30 lb: the fitted branch rises to half its height in 0.07 in, stays
#: below this share for 0.09-0.14 in, then rises again: the measured branches reach 40 % of
#: their rise 0.05 in after a reversal and 60 % only 0.23 in after it).
DEAD_BAND_SLOPE = 0.3
#: Share of the branch's rise that defines the travel of the mean slope above.
RISE_SHARE = 0.95
#: Backlash widths tried, as shares of the input's range (training rows): 1.25 % to 25 %.
GAP_GRID = tuple(0.0125 * k for k in range(1, 21))
#: A gap replaces the fit without one when it lowers the training MSE by this share (on the
#: friction damper at 1 Hz, 30 lb it lowers it by ~25 %; on stop-operator plants without a
#: gap the best width gains < 3 %).
GAP_MIN_GAIN = 0.1
#: Alternations (simulate ``v``, refit the weights on it) per width, at most (a plant with
#: a known gap needs about 10 to recover its weights to the noise; fewer stop at a
#: fixed point of the alternation).
GAP_ITERATIONS = 12
#: Golden-section steps refining the best width of the grid.
GAP_REFINE = 4
#: Alternations of the slip force by direction (fit the gains of the two signs of the
#: force on the bank's output, refit the bank on the output mapped back), at most.
SIGNED_ITERATIONS = 4
#: The gains by direction replace the symmetric fit when they lower the training rows' MSE
#: by this share (as the gap does), and are tried only when two gains on the fitted bank
#: lower the MSE of one gain by it (friction damper: 52 % at 36 lb, 0-6 % at 30 lb).
SIGNED_MIN_GAIN = 0.1
GOLDEN = (np.sqrt(5.0) - 1.0) / 2.0


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
    gap : float
        Width of the backlash gap in series (input units): the force stays zero while the
        input crosses it, wherever the reversal was; 0 without one.
    ratio : float
        The slip force while the force is negative over the one while it is positive
        (:class:`core.stages.SignedGain` after the bank): 1 when it does not depend on the
        sliding direction.
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
    gap: float = 0.0
    ratio: float = 1.0

    def text(self, input_unit: str = "input units", output_unit: str = "output units") -> str:
        """The features in words."""
        out = (f"friction plateau {self.plateau:.4g} {output_unit} (reached "
               f"{self.slip_travel:.4g} {input_unit} after a reversal)")
        if self.ratio != 1.0:
            out += (f"; the slip force depends on the sliding direction: the plateau is "
                    f"{self.plateau:.4g} {output_unit} where the force is positive and "
                    f"{self.plateau * self.ratio:.4g} {output_unit} where it is negative "
                    f"({self.ratio:.3g} times as large)")
        if self.gap > 0:
            out += (f"; backlash dead band {self.gap:.3g} {input_unit} wide: the force stays "
                    "at zero while the input crosses it, half-way through every transition "
                    "between the plateaus")
        if self.dead_band > 0:
            out += (f"; dead band (backlash) {self.dead_band:.4g} {input_unit} wide, "
                    f"starting {self.dead_band_start:.4g} {input_unit} after every reversal, "
                    f"at {self.dead_band_level:.0%} of the branch's rise")
        elif self.concave and self.gap == 0:
            out += ("; a dead band after the reversals cannot show with non-negative element "
                    "weights (fit with --constraint slopes to let the branch flatten and rise "
                    "again)")
        elif self.gap == 0:
            out += "; no dead band after the reversals"
        return out


def branch_features(model: StopPIModel, ratio: float = 1.0) -> BranchFeatures:
    """The plateau and the dead band of ``model``'s branch (:class:`BranchFeatures`);
    ``ratio`` is the slip force's ratio by direction (:attr:`BranchFeatures.ratio`).

    A branch after a reversal rises by ``2 φ(Δu / 2)`` over the travel ``Δu`` (Masing's
    rule, the loading curve ``φ``), piecewise linear with slope ``S_i`` while
    ``2 r_{i-1} < Δu < 2 r_i``.
    """
    r = model.thresholds
    gap = float(model.gap)
    S = model.slopes  # S[0] before the first element slips ... S[n] = k
    edges = np.concatenate(([0.0], 2.0 * r))
    widths = np.diff(edges)
    rise = float(np.sum(S[:-1] * widths))
    travel = float(edges[-1])
    plateau = model.friction_plateau
    concave = bool((model.weights >= 0).all())
    if rise <= 0 or travel <= 0:
        return BranchFeatures(plateau, travel, 0.0, 0.0, 0.0, concave, gap, ratio)
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
    return BranchFeatures(plateau, travel, *best, concave=concave, gap=gap, ratio=ratio)


def _started(model: StopPIModel, u: Float1D) -> StopPIModel:
    """``model`` with every element at rest at ``u``'s first sample."""
    return dataclasses.replace(model, state0=np.full(model.n, float(u[0])))


def _bank_outputs(model: StopPIModel, us: list[Float1D]) -> list[Float1D]:
    """The bank's output (no offset, no gain) of each recording, started at its first
    input sample."""
    return [_started(model, uu)(uu) for uu in us]


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
    signed_gain_ : SignedGain or None
        The gain by the force's sign after the bank (module docstring; ``signed=False``
        never fits one), ``None`` when the symmetric fit was kept; ``full_model_`` is then
        ``model_ >> signed_gain_ >> Offset(offset_)``.
    (others as :class:`~core.fitting.pi.PIRegressor`)
    """

    def __init__(self, *args: Any, gap: float | str = "auto", signed: bool = True,
                 **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.gap = gap
        self.signed = signed
        self.signed_gain_: SignedGain | None = None

    def _constraint_for(self, orientation: LoopOrientation) -> str:
        if self.constraint == "nonnegative":
            return "stop"
        return super()._constraint_for(orientation)

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Fit as :class:`PIRegressor`, then the backlash gap (module docstring).

        ``gap``: ``"auto"`` tries :data:`GAP_GRID`, a number (input units) fits that width,
        0 fits none.
        """
        if isinstance(self.gap, str) and self.gap != "auto":
            raise ParameterError(f"gap must be 'auto' or a width >= 0 in input units, got "
                                 f"{self.gap!r}")
        fixed = None if isinstance(self.gap, str) else float(self.gap)
        if fixed is not None and not (np.isfinite(fixed) and fixed >= 0):
            raise ParameterError(f"gap must be a width >= 0 in input units, got {fixed!r}")
        super()._fit(u, y, train, test)
        self.gap_scores_: dict[float, float] = {}
        if fixed == 0.0 or (fixed is None and not self.orientation_.clockwise):
            return  # (a stop bank misses counter-clockwise loops with or without a gap)
        u, y = unpack_recordings(u, y)
        prep = prepare(u, y, train, test, validation=self.validation, min_train=1)
        trm = prep.train_masks
        span = max(float(np.ptp(x[m])) for x, m in zip(prep.us, trm, strict=True) if m.any())

        def train_mse(model: StopPIModel, offset: float) -> float:
            e = np.concatenate([(yy - zz - offset)[m] for zz, yy, m in zip(
                _bank_outputs(model, prep.us), prep.ys, trm, strict=True)])
            return float(e @ e) / max(e.size, 1)

        base = self.gap_scores_[0.0] = train_mse(self.model_, self.offset_)
        widths = [fixed] if fixed is not None else [g * span for g in GAP_GRID]
        best: tuple[float, float, StopPIRegressor] | None = None
        for b in widths:
            est = self._gap_fit(prep, b)
            mse = train_mse(est.model_, est.offset_)
            self.gap_scores_[b] = mse
            if best is None or mse < best[0]:
                best = (mse, b, est)
        assert best is not None
        if fixed is None:  # golden-section refinement between the grid's neighbours
            step = GAP_GRID[0] * span
            lo, hi = max(best[1] - step, 0.5 * step), best[1] + step
            for _ in range(GAP_REFINE):
                a, c = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
                fits = [(self._gap_fit(prep, x), x) for x in (a, c)]
                scores = [train_mse(e.model_, e.offset_) for e, _ in fits]
                for (e, x), sc in zip(fits, scores, strict=True):
                    self.gap_scores_[x] = sc
                    if sc < best[0]:
                        best = (sc, x, e)
                if scores[0] < scores[1]:
                    hi = c
                else:
                    lo = a
        mse, b, est = best
        if fixed is None and mse > (1.0 - GAP_MIN_GAIN) * base:
            b = 0.0
        else:
            self._take_gap(est, prep, b)
        if self.signed:
            self._fit_signed(prep, b, train_mse(self.model_, self.offset_))

    def _fit_signed(self, prep: Any, b: float, base: float) -> None:
        """The slip force by direction (module docstring): ``y = c + g+ z`` where the bank's
        output ``z >= 0``, ``c + g- z`` where ``z < 0``, by alternation on the training rows
        (``c, g+, g-`` by least squares on ``z``; the bank refitted, without an offset, on
        the output mapped back ``(y - c) / g``); adopted when it lowers the training MSE
        (``base``) by :data:`SIGNED_MIN_GAIN`."""
        trm = prep.train_masks
        ys = np.concatenate([y[m] for y, m in zip(prep.ys, trm, strict=True)])
        model = self.model_
        best: tuple[float, StopPIModel, float, float, float] | None = None
        screen: dict[str, float] = {}
        for _ in range(SIGNED_ITERATIONS):
            z = np.concatenate([zz[m] for zz, m in zip(_bank_outputs(model, prep.us), trm,
                                                        strict=True)])
            A = np.column_stack((np.ones(z.size), np.maximum(z, 0.0), np.minimum(z, 0.0)))
            coef = np.linalg.lstsq(A, ys, rcond=None)[0]
            c, gp, gn = (float(x) for x in coef)
            if not (gp > 0 and gn > 0):
                break
            e = ys - A @ coef
            mse = float(e @ e) / max(e.size, 1)
            if best is None:  # the screen: the two gains against one on the same bank
                A1 = A[:, :2] + np.column_stack((np.zeros(z.size), np.minimum(z, 0.0)))
                e1 = ys - A1 @ np.linalg.lstsq(A1, ys, rcond=None)[0]
                one = float(e1 @ e1) / max(e1.size, 1)
                screen = {"one gain on the first bank": one, "two gains on the first bank": mse}
                if mse > (1.0 - SIGNED_MIN_GAIN) * one:
                    break
            if best is None or mse < best[0]:
                best = (mse, model, c, gp, gn)
            back = [np.where(y - c >= 0, (y - c) / gp, (y - c) / gn) for y in prep.ys]
            model = self._gap_fit(dataclasses.replace(prep, ys=back), b,
                                  include_offset=False).model_
        self.signed_scores_ = {"symmetric": base, **screen,
                               **({} if best is None else {"by direction": best[0]})}
        if best is None or best[0] > (1.0 - SIGNED_MIN_GAIN) * base:
            self.report_ = dataclasses.replace(self.report_, extra={
                **self.report_.extra, "signed_training_mse": dict(self.signed_scores_)})
            return
        _, model, c, gp, gn = best
        self.model_ = dataclasses.replace(model, k=model.k * gp, weights=model.weights * gp)
        self.signed_gain_ = SignedGain(1.0, gn / gp)
        self.offset_ = c
        self.full_model_ = Chain.of(self.model_, self.signed_gain_, Offset(self.offset_))
        tr, te, cmax, crmse = evaluate_fit(self._model_for, self.offset_, prep.segments(1),
                                           train_labels=(0,), test_labels=(1,))
        extra = {**self.report_.extra, **self._extra(),
                 "signed_training_mse": dict(self.signed_scores_)}
        self.report_ = dataclasses.replace(
            self.report_, train=tr, test=te if prep.n_test else None,
            compensation_max_abs=cmax, compensation_rmse=crmse,
            n_parameters=self.report_.n_parameters + 1, extra=extra)

    def _model_for(self, u: Float1D) -> Any:
        m = super()._model_for(u)
        gain = getattr(self, "signed_gain_", None)
        return m if gain is None else Chain.of(m, gain)

    def _gap_fit(self, prep: Any, b: float, **options: Any) -> StopPIRegressor:
        """Weights refitted on the elements' input behind a gap ``b`` wide (``options``
        replace the estimator's own, e.g. ``include_offset``)."""
        names = inspect.signature(PIRegressor.__init__).parameters
        params = {**{k: getattr(self, k) for k in names if k != "self"}, "gap": 0.0,
                  "signed": False, "n_operators": self.n_operators_, **options}
        model, est, last = self.model_, self, None
        for _ in range(GAP_ITERATIONS):
            m = dataclasses.replace(model, gap=b)
            vs = [_started(m, uu).bank_input(uu) for uu in prep.us]
            if last is not None and max(float(np.max(np.abs(v - w)))
                                        for v, w in zip(vs, last, strict=True)) <= 1e-6 * b:
                break  # the elements' input no longer moves: converged
            last = vs
            est = _GapStep(**params)
            est.served_orientation_ = self.orientation_
            with FILTERS, warnings.catch_warnings():
                warnings.simplefilter("ignore")
                est.fit(vs if prep.multi else vs[0], prep.ys if prep.multi else prep.ys[0],
                        train=prep.train_masks if prep.multi else prep.train_masks[0],
                        test=prep.test_masks if prep.multi else prep.test_masks[0])
            model = est.model_
        est.model_ = dataclasses.replace(est.model_, gap=b)
        return est

    def _take_gap(self, est: StopPIRegressor, prep: Any, b: float) -> None:
        """Adopt ``est``'s gap fit and score it on the input itself."""
        self.model_ = est.model_
        self.offset_ = est.offset_
        self.thresholds_, self.p0_, self.weights_ = est.thresholds_, est.p0_, est.weights_
        self.full_model_ = Chain.of(self.model_, Offset(self.offset_))
        tr, te, cmax, crmse = evaluate_fit(self._model_for, self.offset_, prep.segments(1),
                                           train_labels=(0,), test_labels=(1,))
        extra = {**self.report_.extra, **self._extra(), "gap": b,
                 "gap_training_mse": {f"{k:.4g}": v for k, v in self.gap_scores_.items()}}
        self.report_ = dataclasses.replace(
            self.report_, train=tr, test=te if prep.n_test else None,
            compensation_max_abs=cmax, compensation_rmse=crmse,
            n_parameters=self.report_.n_parameters + 1, extra=extra)

    def _build(self, p0: float, r: Float1D, w: Float1D, u0: float) -> StopPIModel:
        k = float(p0 + np.sum(w))
        return StopPIModel(k, r, -np.asarray(w), np.full(r.size, u0))

    def _extra(self) -> dict[str, Any]:
        gain = getattr(self, "signed_gain_", None)
        self.features_ = branch_features(self.model_,
                                         1.0 if gain is None else gain.ratio)
        f = self.features_
        out = {"friction_plateau": f.plateau, "slip_travel": f.slip_travel,
               "dead_band": f.dead_band, "dead_band_start": f.dead_band_start,
               "gap": f.gap, "branch": f.text()}
        if gain is not None:
            out["slip_force_ratio"] = gain.ratio
            out["friction_plateau_falling"] = f.plateau * gain.ratio
        return out

    # the weights in the report are the stop form's
    @property
    def stiffness_(self) -> float:
        """``k`` of the fitted model (output per input unit)."""
        return float(self.model_.k)


class _GapStep(StopPIRegressor):
    """One weight fit of the gap search (:meth:`StopPIRegressor._gap_fit`): the bank on the
    elements' input behind a fixed gap, fitted as :class:`StopPIRegressor` (``gap=0``) but
    not scored (no ``report_``): the search reads only its model and offset, and the width
    it keeps is scored on the input itself (``_take_gap``)."""

    scores_fit: ClassVar[bool] = False
    #: The orientation of the fit the search serves (the loops of its input itself), set by
    #: :meth:`StopPIRegressor._gap_fit` and taken as the step's own: the step's orientation
    #: on the elements' input is read by nothing (the stop bank's constraint does not depend
    #: on it, :meth:`StopPIRegressor._constraint_for`, and the step is not scored), so it is
    #: not computed (an eighth of the search's time on the pinched steel plant).
    served_orientation_: LoopOrientation

    def _orientation(self, prep: Any) -> LoopOrientation:
        return self.served_orientation_
