"""Base hysteresis families other than the PI for the diagnosis: a Bouc-Wen bank, a
Menegotto-Pinto bank (non-Masing loops) and the stop-operator base of clockwise loops; and
the declaration of every base kind a diagnosis may have, the PI and the Preisach base
included, with its words (:class:`BaseKind`, :data:`BASE_KINDS`).

A Bouc-Wen base is the registered :class:`~core.boucwen.BoucWenModel`
``y = k u + sum_j c_j z_j`` with rate-independent Bouc-Wen elements

    dz_j/du = 1 - (beta_j sign(du z_j) + gamma_j) |z_j|^n_j,

each of a fixed shape (``beta_j, gamma_j, n_j``) from a generic grid scaled to the input range
(:func:`bouc_wen_elements`), so the model is linear in its weights and is fitted as the PI
is, jointly with the effects (:func:`core.diagnosis.structure.fit_structure`). Element ``j``
saturates at ``z_s = (beta_j + gamma_j)^(-1/n_j)`` (the size of its loop, as a play's
threshold is) and its slope ``dz_j/du`` lies in ``[0, m_j]``, ``m_j = max(1, s_j)``,
``s_j = 2 beta_j / (beta_j + gamma_j)``. The bank holds ``[u, m_j u - z_j]``: with weights
``k' >= eps`` and ``w_j >= 0`` (``k = k' + sum_j w_j m_j``, ``c_j = -w_j``) every fitted
model has ``dy/du >= k' > 0`` on every branch, so it inverts (a hardening loop, as the PI's
nonnegative play weights give).

**Menegotto-Pinto base** (non-Masing loops: a knee that rounds with the previous plastic
excursion, as steel's; every play, stop, Preisach and fixed-shape Bouc-Wen branch follows
Masing's rule or one shape): the registered :class:`~core.nonmasing.MenegottoPintoModel`
``y = k u + sum_i w_i s_i[u]`` of smooth stop elements on a generic grid of yield levels
(fractions of the training input range) and literature shapes (:data:`MP_GRID`), in the
training rows' loop orientation: columns ``[u, s_i]`` for clockwise loops, the smooth plays
``[u, u - s_i]`` for counter-clockwise ones, weights ``k' >= eps``, ``w_i >= 0``, so every
branch rises and the model inverts. It rides on the Bouc-Wen bank's path through the
structure (``Structure.bouc_wen`` holds its elements, tagged :data:`MP`), linear in its
weights and fitted jointly with the effects. On the benchmark's Menegotto-Pinto plant with a
concealed drift the base's held-out error falls from 2.47 % (stop base) to 0.45 % of range
and the drift is named instead of an offset.

**Stop-operator base** (clockwise, friction-like loops; the ``stop-pi`` kind of
``hyst fit --model auto``, :mod:`core.fitting.choice`): the registered
:class:`~core.stop.StopPIModel` ``y = k v + sum_i w_i Xi_{r_i}[v]`` with ``k >= eps`` and
``w_i >= 0`` (Maxwell-slip elements), driven by the input behind a backlash gap, ``v``. The
gap's width and the force that opens it come from the fit-side search
(:class:`~core.fitting.stop.StopPIRegressor` with ``gap="auto"`` on the training rows,
:func:`fit_stop_gap`), and ``v`` is simulated once with that model (:func:`stop_input`): for
that fixed ``v`` the base is linear in its weights (the play bank on ``v``, columns
``[v, v - Gamma_{r_i}[v]]``), so the diagnosis fits it jointly with the effects as it fits
the PI. The diagnosed model is the exact :class:`~core.stop.StopPIModel` with that gap (its
own weights decide where the gap opens), which inverts (:class:`~core.stop.StopGapInverse`)
and exports to C and FMU. The base's input map is carried as the first stage of the
structure's shape (:func:`stop_stage`; :mod:`core.diagnosis.shapes`).

**Slip force by direction**: where the same fit adopts a gain by the sign of the force
(:class:`~core.stages.SignedGain`, ``g+`` folded into the bank, ratio ``g- / g+``; its
screen and :data:`~core.fitting.stop.SIGNED_MIN_GAIN` decide, as for ``hyst fit``), the
stage carries the ratio and each row of the bank is multiplied by 1 or the ratio by the sign
of that model's force (:func:`stop_gains`), so the base stays linear in its weights; the
diagnosed model is ``StopPIModel >> SignedGain(1, ratio)``. On the friction damper at 36 lb
(ratio 1.66) the base's held-out error falls from 5.72 to 3.27 % of range and the direction
asymmetry is no longer named as an ``asymmetry`` effect.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .._typing import Float1D
from ..boucwen import BoucWenModel, BoucWenState
from ..fitting.choice import BW_MIN_GAIN as _BW_MIN_GAIN
from ..fitting.choice import MP_MIN_GAIN as _MP_MIN_GAIN
from ..fitting.nonmasing import MP_GRID as _MP_GRID
from ..fitting.nonmasing import grid_elements
from ..nonmasing import MenegottoPintoModel, oriented_bank, oriented_columns
from ..recordings import Recording
from ..stop import StopPIModel

__all__ = [
    "BASE_KINDS",
    "BW_GRID",
    "GAP",
    "BW_MIN_GAIN",
    "MP",
    "MP_GRID",
    "MP_MIN_GAIN",
    "BaseKind",
    "base_elements",
    "element_family",
    "elements_like",
    "element_bank",
    "menegotto_pinto_elements",
    "menegotto_pinto_model",
    "bouc_wen_bank",
    "bouc_wen_elements",
    "bouc_wen_model",
    "fit_stop_gap",
    "initial_state",
    "saturations",
    "stop_gains",
    "stop_input",
    "stop_model",
    "stop_ratio",
    "stop_stage",
]

#: A Bouc-Wen base replaces the PI (or a Preisach base that replaced it;
#: :func:`core.diagnosis.basechoice.choose_base_family`) when it lowers the MSE of predicting
#: each recording from the others by at least this share against the PI, and by more than
#: the Preisach did. Measured (training
#: rows, seed 500/100, white noise): the benchmark's Bouc-Wen plants 0.68-0.93 (nulls),
#: 0.48-0.77 (small creep); Duhem + creep 0.25, Duhem null -1.45, Preisach 0.07, Maxwell-slip
#: -0.71; B-PI + saturation 0.17, + dead-zone -0.24, + asymmetry -4.9, + weak creep < -100.
#: The static-map plants stay below it, so no static-map check is needed (unlike the
#: Preisach, which fits a static map's loops 60-98 % better than the PI). One value shared
#: with ``hyst fit --model auto`` (:mod:`core.fitting.choice`, which makes the same base
#: choice with the fit kinds' estimators).
BW_MIN_GAIN = _BW_MIN_GAIN

#: Kind of the stop base's input map, the first stage of a structure's shape
#: (:mod:`core.diagnosis.shapes`).
GAP = "gap"

#: The generic grid of Bouc-Wen element shapes: saturation ``z_s`` as a fraction of the
#: training input range (a factor 2 apart), smoothness exponents ``n`` and ratios
#: ``gamma / beta`` (reversal slopes ``s`` = 4 and 4/3: unloading faster than loading, the
#: piezo's counter-clockwise loop). Not fitted to the benchmark's plants; how near their
#: truths it lands is in benchmarks/diagnosis/README.md (session 4).
BW_GRID: dict[str, tuple[float, ...]] = {
    "saturation": (0.05, 0.1, 0.2, 0.4),
    "n": (1.0, 2.0),
    "gamma_over_beta": (-0.5, 0.5),
}


def bouc_wen_elements(span: float) -> tuple[tuple[float, float, float], ...]:
    """``(beta, gamma, n)`` of the elements of :data:`BW_GRID` for input range ``span`` (> 0,
    input units)."""
    out = []
    for n in BW_GRID["n"]:
        for frac in BW_GRID["saturation"]:
            for rho in BW_GRID["gamma_over_beta"]:
                s = (frac * span) ** (-n)  # beta + gamma
                beta = s / (1.0 + rho)
                out.append((float(beta), float(rho * beta), float(n)))
    return tuple(out)


def saturations(elements: tuple[tuple[float, float, float], ...]) -> tuple[float, ...]:
    """Saturation ``(beta + gamma)^(-1/n)`` of each element (input units)."""
    return tuple(float((b + g) ** (-1.0 / n)) for b, g, n in elements)


def _slope_caps(elements: tuple) -> np.ndarray:
    """``m_j = max(1, 2 beta_j / (beta_j + gamma_j))``: the largest ``dz_j/du``."""
    return np.array([max(1.0, 2.0 * b / (b + g)) for b, g, _ in elements])


def bouc_wen_model(
    k: float, w: Float1D, elements: tuple, state: BoucWenState | None = None
) -> BoucWenModel:
    """The registered model of bank weights ``k'`` (``k``) and ``w_j`` (see the module
    docstring), started from ``state`` (element variables at an input; by default 0 at
    input 0, as a PI's plays start)."""
    b, g, n = (np.array([e[i] for e in elements], dtype=np.float64) for i in range(3))
    w = np.asarray(w, dtype=np.float64)
    z0, u0 = (None, 0.0) if state is None else (state.z, state.u)
    return BoucWenModel.from_classical(float(k + w @ _slope_caps(elements)), -w, b, g, n, z0, u0)


def initial_state(elements: tuple, hist: Float1D | None) -> BoucWenState | None:
    """Element variables after a virtual history ``hist`` (input extrema before the record,
    from ``z = 0`` at input 0), or ``None`` without one."""
    if hist is None or not len(hist):
        return None
    m = bouc_wen_model(0.0, np.zeros(len(elements)), elements)
    h = np.asarray(hist, dtype=np.float64)
    return BoucWenState(float(h[-1]), m.states(h)[-1].copy())


def bouc_wen_bank(w: Float1D, elements: tuple, hist: Float1D | None = None) -> np.ndarray:
    """``[w, m_1 w - z_1(w), ..., m_n w - z_n(w)]`` ``(N, n + 1)`` (module docstring), the
    elements integrated exactly as :class:`~core.boucwen.BoucWenModel` does, from ``z = 0``
    at input 0 or from the state a virtual history ``hist`` leaves (:func:`initial_state`)."""
    w = np.asarray(w, dtype=np.float64)
    model = bouc_wen_model(0.0, np.zeros(len(elements)), elements)
    st = initial_state(elements, hist)
    B = np.empty((w.size, len(elements) + 1))
    B[:, 0] = w
    if w.size:
        B[:, 1:] = w[:, None] * _slope_caps(elements)[None, :] - model.states(w, st)
    return B


def fit_stop_gap(records: list[Recording], train: list[np.ndarray], test: list[np.ndarray],
                 n_operators: int) -> tuple[StopPIModel, float] | None:
    """The stop-operator model with the backlash gap and the slip force by direction that
    the fit-side search finds on the training rows (:class:`~core.fitting.stop.StopPIRegressor`
    with its defaults, ``gap="auto"`` and ``signed=True``: the width that lowers the training
    MSE by :data:`~core.fitting.stop.GAP_MIN_GAIN`, else none; the gains by direction where
    they lower it by :data:`~core.fitting.stop.SIGNED_MIN_GAIN`, else none; ``n_operators``
    elements), as ``(model, ratio)``: the bank (its gain ``g+`` folded in) and ``g- / g+``
    (1 when the slip force does not depend on the direction); ``None`` when it cannot be
    fitted. ``test`` rows are only passed on, never scored for the choice."""
    import warnings

    from ..exceptions import ParameterError
    from ..fitting.estimator import without_compensation_scores
    from ..fitting.stop import StopPIRegressor
    from ..warning_filters import FILTERS

    use = [k for k, m in enumerate(train) if m.any()]
    if not use:
        return None
    est = StopPIRegressor(n_operators=n_operators, initial_memory="keep", gap="auto")
    multi = len(use) > 1
    us = [records[k].u for k in use]
    ys = [records[k].y for k in use]
    try:
        # (only the model is read: the fit's report does not run its inverse)
        with FILTERS, warnings.catch_warnings(), without_compensation_scores():
            warnings.simplefilter("ignore")
            est.fit(us if multi else us[0], ys if multi else ys[0],
                    train=[train[k] for k in use] if multi else train[use[0]],
                    test=[test[k] for k in use] if multi else test[use[0]])
    except ParameterError:
        return None
    gain = est.signed_gain_
    return est.model_, 1.0 if gain is None else float(gain.ratio)


def stop_stage(model: StopPIModel, ratio: float = 1.0) -> tuple:
    """The stop base's input map ``("gap", b, k, r, w)`` of ``model`` (hashable): the gap's
    width and the model whose force decides where the gap opens; with a slip force by
    direction (``ratio = g- / g+ != 1``, :class:`~core.stages.SignedGain` after the bank)
    ``("gap", b, k, r, w, ratio)``, the same model's force also deciding which of the two
    gains applies (:func:`stop_gains`)."""
    stage = (GAP, float(model.gap), float(model.k),
             tuple(float(x) for x in model.thresholds), tuple(float(x) for x in model.weights))
    return stage if ratio == 1.0 else (*stage, float(ratio))


def stop_ratio(stage: tuple) -> float:
    """The slip force's ratio by direction ``g- / g+`` of ``stage`` (:func:`stop_stage`),
    1 without one."""
    return float(stage[5]) if len(stage) > 5 else 1.0


def _stage_model(stage: tuple) -> StopPIModel:
    """The model of ``stage`` (:func:`stop_stage`) whose force decides the gap and the
    gain, relaxed at 0."""
    _, b, k, r, w = stage[:5]
    return StopPIModel(k, np.asarray(r), np.asarray(w), gap=b)


def stop_input(stage: tuple, u: Float1D) -> Float1D:
    """The input behind the gap of ``stage`` (:func:`stop_stage`), ``v`` of shape ``(N,)``
    (input units), simulated from relaxed sliders at 0 as the diagnosed model starts; ``u``
    itself without a gap."""
    uu = np.ascontiguousarray(u, dtype=np.float64)
    if stage[1] <= 0 or not uu.size:
        return uu.copy()
    return _stage_model(stage).bank_input(uu)


def stop_gains(stage: tuple, u: Float1D) -> Float1D | None:
    """The gain of the slip force by direction on each sample of ``u``, shape ``(N,)``: 1
    where the force of ``stage``'s model (relaxed at 0, as :func:`stop_input`) is
    non-negative, :func:`stop_ratio` where it is negative; ``None`` without a ratio. For
    that fixed pattern the bank times the gains is linear in the weights, as the bank on
    the gap's input is (the diagnosed model's own force decides, as it does for the gap)."""
    ratio = stop_ratio(stage)
    if ratio == 1.0:
        return None
    uu = np.ascontiguousarray(u, dtype=np.float64)
    return np.where(_stage_model(stage)(uu) >= 0, 1.0, ratio) if uu.size else np.ones(0)


def stop_model(stage: tuple, r: Float1D, p0: float, pw: Float1D,
               state0: Float1D | None = None) -> StopPIModel:
    """The stop-operator model behind the gap of ``stage`` with thresholds ``r`` (``(n,)``,
    input units) and play-frame weights ``p0, pw`` (the bank ``[v, Gamma_{r_i}[v]]``'s):
    ``k = p0 + sum pw``, ``w_i = -pw_i`` (``Xi_r = I - Gamma_r``); sliders at ``state0``
    (zeros by default)."""
    pw = np.asarray(pw, dtype=np.float64)
    return StopPIModel(float(p0 + pw.sum()), np.asarray(r, dtype=np.float64), -pw,
                       state0, gap=float(stage[1]))


# ---------------------------------------------------------------------------------------
# Menegotto-Pinto base (non-Masing loops)

#: First item of a Menegotto-Pinto element's tuple in a structure's element bank
#: (``Structure.bouc_wen``): ``(MP, sign, r, R0, cR1, cR2)``, where the Bouc-Wen elements are
#: ``(beta, gamma, n)``.
MP = "menegotto-pinto"


# ---------------------------------------------------------------------------------------
# The base kinds (each declared once, with its words)

@dataclass(frozen=True)
class BaseKind:
    """One base hysteresis kind of a diagnosis
    (:attr:`~core.diagnosis.structure.Structure.base_kind`, the ``kind`` of
    :class:`~core.diagnosis.results.BaseChoice`), declared once with its words.

    Attributes
    ----------
    name : str
        The kind as the JSON documents write it (``"pi"``, ``"stop-pi"``, ...), the family
        name of :func:`core.fitting.choice.base_family`.
    short : str
        Its short name, as in "the PI model" or "the Menegotto-Pinto ... against it" (the
        explorer's findings, the base choice's words).
    long : str
        Its name with what it is made of, as the report names an alternative base ("a
        stop-operator (Maxwell-slip, backlash gap) base").
    """

    name: str
    short: str
    long: str


#: Every base kind of a diagnosis by name (:class:`BaseKind`): what the report
#: (:mod:`core.diagnosis.misspecification`, :mod:`core.diagnosis.results`) and the explorer
#: (:mod:`app.services.analysis.diagnosis`) call each.
BASE_KINDS: Mapping[str, BaseKind] = MappingProxyType({k.name: k for k in (
    BaseKind("pi", "PI", "PI"),
    BaseKind("stop-pi", "stop-operator", "stop-operator (Maxwell-slip, backlash gap)"),
    BaseKind("preisach", "Preisach", "Preisach"),
    BaseKind("bouc-wen", "Bouc-Wen", "Bouc-Wen"),
    BaseKind(MP, "Menegotto-Pinto", "Menegotto-Pinto (non-Masing smooth stop elements)"),
)})

#: A Menegotto-Pinto base replaces the chosen base when it lowers the MSE of predicting each
#: recording from the others by at least this share against the PI (or stop) base and beats
#: the chosen base: the same margin as the Bouc-Wen bank's (:data:`BW_MIN_GAIN`), a choice of
#: the base, not a physics claim. One value shared with ``hyst fit --model auto``.
MP_MIN_GAIN = _MP_MIN_GAIN

#: The generic grid of Menegotto-Pinto elements (yield levels as fractions of the training
#: input range, literature shapes), shared with ``hyst fit``'s Menegotto-Pinto kind
#: (:data:`core.fitting.nonmasing.MP_GRID`).
MP_GRID = _MP_GRID


def menegotto_pinto_elements(span: float, sign: float) -> tuple[tuple, ...]:
    """``(MP, sign, r, R0, cR1, cR2)`` of the elements of :data:`MP_GRID` for the input range
    ``span`` (> 0, input units); ``sign`` +1 for clockwise loops (columns ``s_i``), -1 for
    counter-clockwise ones (the smooth plays ``u - s_i``)."""
    return tuple((MP, float(sign), *(float(x) for x in row))
                 for row in zip(*grid_elements(span), strict=True))


def element_family(elements: tuple) -> str:
    """``"menegotto-pinto"`` or ``"bouc-wen"``: the family of a structure's element bank."""
    return MP if elements and elements[0][0] == MP else "bouc-wen"


def elements_like(elements: tuple, span: float) -> tuple:
    """The generic grid of ``elements``' family (and orientation) for the input range
    ``span``."""
    if element_family(elements) == MP:
        return menegotto_pinto_elements(span, elements[0][1])
    return bouc_wen_elements(span)


def _mp_parts(elements: tuple) -> tuple[float, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``sign, r, R0, cR1, cR2`` of Menegotto-Pinto elements (arrays of shape ``(n,)``)."""
    a = np.array([e[1:] for e in elements], dtype=np.float64)
    return float(a[0, 0]), a[:, 1], a[:, 2], a[:, 3], a[:, 4]


def menegotto_pinto_model(k: float, w: Float1D, elements: tuple,
                          hist: Float1D | None = None) -> MenegottoPintoModel:
    """The registered model of bank weights ``k'`` (``k``) and ``w_i`` on Menegotto-Pinto
    ``elements`` (:func:`menegotto_pinto_elements`): clockwise ``k = k'`` and ``w``;
    counter-clockwise (columns ``u - s_i``) ``k = k' + sum w`` and ``-w``; started after the
    virtual input history ``hist`` (from the virgin state at 0)."""
    sign, r, r0, c1, c2 = _mp_parts(elements)
    h = None if hist is None or not len(hist) else np.asarray(hist, dtype=np.float64)
    return oriented_bank(k, w, r, r0, c1, c2, sign > 0, history=h)


def element_bank(w: Float1D, elements: tuple, hist: Float1D | None = None) -> np.ndarray:
    """The bank ``(N, n + 1)`` of a structure's fixed-shape elements on the input ``w``:
    :func:`bouc_wen_bank`, or for Menegotto-Pinto elements ``[w, c_1, ..., c_n]`` with
    ``c_i = s_i(w)`` (clockwise) or ``w - s_i(w)`` (counter-clockwise), the elements run
    exactly as :class:`~core.nonmasing.MenegottoPintoModel` runs them after ``hist``."""
    if element_family(elements) != MP:
        return bouc_wen_bank(w, elements, hist)
    w = np.ascontiguousarray(w, dtype=np.float64)
    sign = _mp_parts(elements)[0]
    S = menegotto_pinto_model(1.0, np.zeros(len(elements)), elements, hist).element_outputs(w)
    B = np.empty((w.size, len(elements) + 1))
    B[:, 0] = w
    B[:, 1:] = oriented_columns(w, S, sign > 0)
    return B


def base_elements(elements: tuple) -> tuple[float, ...]:
    """The ``thresholds`` a structure carries for its element bank: each element's size
    (the Bouc-Wen saturation, the Menegotto-Pinto yield level), input units."""
    if element_family(elements) == MP:
        return tuple(float(e[2]) for e in elements)
    return saturations(elements)
