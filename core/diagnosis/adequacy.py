"""Base-model adequacy: is what is left at the noise floor, and if not, which model class helps?

"No missing physics" may only be said when the final residual is at the white-noise floor.
When it stays well above it (:data:`INADEQUATE_RATIO` times), the verdict says so in words:
how much of the range is still missed, where, what was tried, and which model class of the
core explains more of it. The classes tried are the fit kinds of the model registry
(:func:`core.models.fit_kinds`, every type that declares an estimator) other than the base
PI, each fitted by its own estimator (:mod:`core.fitting`) on the training rows: Kuhnen's
modified PI (an output superposition of one-sided dead zones), the dead-zone GPI (a threshold
/ dead band at the input), the tanh-envelope GPI (saturation), the digitized PI, and any
type registered later. The loop shapes the diagnosis itself models (``saturation``,
``dead-zone``: :mod:`core.diagnosis.shapes`) are candidates of the effect search; this verdict
is the check that the final model is not still far from what the generalized fits reach.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..fitting.adequacy import rate_trend, rate_words
from ..fitting.estimator import without_compensation_scores
from ..recordings import Recording
from ..warning_filters import FILTERS

__all__ = ["INADEQUATE_RATIO", "Adequacy", "LoopShapeFit", "assess", "largest_region",
           "loop_shape_kinds", "where_residual"]

#: Final RMS residual over the white-noise floor above which the base model is inadequate.
INADEQUATE_RATIO = 2.0

#: Most training rows the loop-shape fits are solved on; longer recordings are thinned to
#: every k-th training row for them (their cost is linear).
MAX_SAMPLES = 60_000

#: What a fit kind represents, in words, where the registry title does not say it.
PHYSICS: dict[str, str] = {
    "mpi": "saturation or a one-sided output map (Kuhnen's superposition of output "
           "dead-zones)",
    "gpi-deadzone": "a threshold / dead band at the input (dead-zone GPI)",
    "gpi-tanh": "saturation of the loop branches (tanh-envelope GPI)",
    "preisach": "level-dependent memory: minor loops whose width changes with the bias level "
                "(Preisach density varying along (alpha+beta)/2)",
    "stop-pi": "friction: Maxwell-slip elements (stop operators) that slide on a friction "
               "plateau, behind a backlash gap where the fit finds one",
    "menegotto-pinto": "non-Masing loops: smooth stop elements whose knee rounds after a "
                       "large excursion (a steel's Menegotto-Pinto law)",
}


def loop_shape_kinds() -> tuple[tuple[str, str], ...]:
    """``(fit kind, physics in words)`` of every registered fit kind except the base PI."""
    from ..models import DEFAULT_FIT_KIND, fit_kinds, model_type

    return tuple((k, PHYSICS.get(k, model_type(k).title)) for k in fit_kinds()
                 if k != DEFAULT_FIT_KIND)


@dataclass(frozen=True)
class LoopShapeFit:
    """One loop-shape model class fitted on the training rows.

    Attributes
    ----------
    model : str
        ``hyst fit --model`` name.
    physics : str
        What the class represents, in words.
    rmse : float
        RMSE on the scored rows (output units).
    pct : float
        The same in % of the output range of the scored rows.
    model_dict : dict
        The fitted model (``to_dict()``, offsets included).
    """

    model: str
    physics: str
    rmse: float
    pct: float
    model_dict: dict[str, Any]


@dataclass(frozen=True)
class Adequacy:
    """The base-model adequacy verdict.

    Attributes
    ----------
    adequate : bool
        The final residual is within :data:`INADEQUATE_RATIO` of the noise floor.
    residual_rmse, noise_rms : float
        Final RMS residual and white-noise floor on the scored rows (output units).
    pct : float
        Final RMSE in % of the output range of the scored rows.
    scored : str
        Which rows were scored.
    loop_shapes : tuple of LoopShapeFit
        The loop-shape classes tried (empty when adequate or too long).
    text : str
        The verdict in words.
    largest_region : tuple of float, optional
        ``(input low, input high, RMS)``: the input-level decile of the scored rows where
        the residual is largest (input units) and its RMS there (output units); ``None``
        when adequate or with too few rows.
    rate_trend : tuple of (str, float, float, float)
        ``(recording, mean input speed, residual RMS, width misfit)`` per recording (input
        units per second, output units), slowest first, when the misfit changes with the
        rate (:func:`core.fitting.adequacy.rate_trend`); empty otherwise.
    """

    adequate: bool
    residual_rmse: float
    noise_rms: float
    pct: float
    scored: str
    loop_shapes: tuple[LoopShapeFit, ...]
    text: str
    largest_region: tuple[float, float, float] | None = None
    rate_trend: tuple[tuple[str, float, float, float], ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"adequate": self.adequate, "residual_rmse": self.residual_rmse,
                "noise_rms": self.noise_rms, "pct": self.pct, "scored": self.scored,
                "loop_shapes": [{"model": f.model, "physics": f.physics, "rmse": f.rmse,
                                 "pct": f.pct, "model_dict": f.model_dict}
                                for f in self.loop_shapes],
                "text": self.text,
                "largest_region": (None if self.largest_region is None
                                   else list(self.largest_region)),
                "rate_trend": [list(t) for t in self.rate_trend]}


def _fit_shape(kind: str, records: Sequence[Recording], train, test, free: bool):
    from ..models import estimator_class

    est = estimator_class(kind)(constraint="slopes" if free else "nonnegative")
    us = [r.u for r in records]
    ys = [r.y for r in records]
    # (only the predictions are read: the fit's report does not run its inverse)
    with FILTERS, warnings.catch_warnings(), without_compensation_scores():
        warnings.simplefilter("ignore")
        est.fit(us, ys, train=list(train), test=list(test))
    pred = est.predict(us)
    return est, pred


def fold_mse(kind: str, records: Sequence[Recording], folds, free: bool = False) -> float:
    """Pooled MSE of fit kind ``kind`` (its own ``core.fitting`` estimator) over ``folds``,
    each ``(train masks, block masks)``: fitted without the block, scored on it; NaN when
    the estimator cannot fit a fold."""
    sse, n = 0.0, 0
    for tr, blk in folds:
        try:
            _, pred = _fit_shape(kind, records, tr, blk, free)
        except (ValueError, RuntimeError, np.linalg.LinAlgError):
            return float("nan")
        for r, p_, m in zip(records, pred, blk, strict=True):
            e = (r.y - p_)[m]
            sse += float(e @ e)
            n += int(m.sum())
    return sse / n if n else float("nan")


def largest_region(records: Sequence[Recording], pred: Sequence[np.ndarray],
                   rows: Sequence[np.ndarray]) -> tuple[float, float, float, float] | None:
    """``(input low, input high, RMS, RMS / overall RMS)`` of the input-level decile of
    ``rows`` where the residual is largest (input units, output units); ``None`` with fewer
    than 20 rows."""
    u = np.concatenate([r.u[m] for r, m in zip(records, rows, strict=True)])
    e = np.concatenate([(r.y - p)[m] for r, p, m in zip(records, pred, rows, strict=True)])
    if e.size < 20:
        return None
    edges = np.quantile(u, np.linspace(0, 1, 11))
    k = np.clip(np.searchsorted(edges, u, side="right") - 1, 0, 9)
    rms = np.array([np.sqrt(np.mean(e[k == j] ** 2)) if np.any(k == j) else 0.0
                    for j in range(10)])
    j = int(np.argmax(rms))
    tot = float(np.sqrt(np.mean(e * e)))
    return float(edges[j]), float(edges[j + 1]), float(rms[j]), float(rms[j] / tot)


def where_residual(records: Sequence[Recording], pred: Sequence[np.ndarray],
                   rows: Sequence[np.ndarray]) -> str:
    """Where the residual concentrates, in words and in the recordings' units: the
    input-level decile with the largest RMS (:func:`largest_region`: input units, its RMS
    in output units), the branches, and how the misfit changes with the input's rate across
    recordings (:func:`rate_trend`)."""
    region = largest_region(records, pred, rows)
    if region is None:
        return ""
    lo, hi, rms, over = region
    du = np.concatenate([np.gradient(r.u)[m] for r, m in zip(records, rows, strict=True)])
    e = np.concatenate([(r.y - p)[m] for r, p, m in zip(records, pred, rows, strict=True)])
    units = records[0].units
    ui = f" {units['input']}" if units.get("input") else " (input units)"
    uo = f" {units['output']}" if units.get("output") else ""
    up, dn = e[du > 0], e[du < 0]
    br = ""
    if up.size and dn.size:
        a, b = float(np.sqrt(np.mean(up**2))), float(np.sqrt(np.mean(dn**2)))
        br = (f"; ascending branch RMS {a:.3g}{uo}, descending {b:.3g}{uo}"
              + (" (one-sided)" if max(a, b) > 1.5 * min(a, b) else ""))
    rate = rate_words(records, rate_trend(records, pred, rows))
    return (f"largest at input {lo:.4g}..{hi:.4g}{ui} (RMS {rms:.3g}{uo}, "
            f"{over:.1f} times the average){br}" + (f"; {rate}" if rate else ""))


def assess(
    records: Sequence[Recording],
    train: Sequence[np.ndarray],
    test: Sequence[np.ndarray],
    final_pred: Sequence[np.ndarray],
    noise_rms: float,
    tried: Sequence[str],
    free_weights: bool,
    found: Sequence[str] = (),
) -> Adequacy:
    """Judge the final model against the noise floor and try the loop-shape classes.

    Parameters
    ----------
    records, train, test : the diagnosis' recordings and row masks
        The test rows are scored; without any, the training rows (in-sample, said so).
    final_pred : sequence of ndarray
        The final model's prediction per recording.
    noise_rms : float
        White-noise floor (output units).
    tried : sequence of str
        Effects tested.
    free_weights : bool
        The baseline needed play weights of either sign (saturating loop): the loop-shape
        classes are then fitted with the loop-slope constraint.
    found : sequence of str
        Effects in the final model (a loop shape among them is named in the verdict).

    Returns
    -------
    Adequacy
    """
    has_test = any(m.any() for m in test)
    rows = test if has_test else train
    scored = "the held-out rows" if has_test else "the training rows (in-sample)"
    ys = [r.y[m] for r, m in zip(records, rows, strict=True)]
    e = np.concatenate([(r.y - p)[m] for r, p, m in zip(records, final_pred, rows, strict=True)])
    rmse = float(np.sqrt(np.mean(e * e)))
    from ..fitting.metrics import percent_of_range

    pct = percent_of_range(rmse, ys)
    ratio = rmse / noise_rms if noise_rms > 0 else np.inf
    where = where_residual(records, final_pred, rows)
    from .shapes import SHAPE_EFFECTS

    shape = [e for e in found if e in SHAPE_EFFECTS.values()]
    with_shape = (f" (with the loop shape the search found: {', '.join(shape)})" if shape
                  else "")
    if ratio <= INADEQUATE_RATIO:
        return Adequacy(True, rmse, noise_rms, pct, scored, (), (
            f"the final model{with_shape} is adequate: its residual ({rmse:.4g}, "
            f"{pct:.3f} % of range, "
            f"{ratio:.1f} times the white-noise floor {noise_rms:.3g}) is within "
            f"{INADEQUATE_RATIO:g} times that floor: no missing physics left to find in "
            "these recordings"))
    shapes, fitted, thin = _fit_shapes(records, train, rows, free_weights, ys)
    text = (f"the base model is not adequate: the final model{with_shape} still misses "
            f"{pct:.2f} % of the "
            f"output range on {scored} (RMS {rmse:.4g}, {ratio:.1f} times the white-noise floor "
            f"{noise_rms:.3g}); {where or 'spread over the record'}. Tried: "
            f"{', '.join(tried) or 'no effect'}.")
    trend = rate_trend(records, final_pred, rows)
    from ..fitting.physicsleft import physics_left

    left = physics_left(records, noise_rms).text(dict(records[0].units))
    text += _shape_words(records, shapes, fitted, rmse, rate=bool(trend), left=left)
    if thin > 1 and shapes:
        text += f" (The other classes were fitted on every {thin}th training row.)"
    region = largest_region(records, final_pred, rows)
    return Adequacy(False, rmse, noise_rms, pct, scored, tuple(shapes), text,
                    None if region is None else region[:3], trend)


def _fit_shapes(records: Sequence[Recording], train: Sequence[np.ndarray],
                rows: Sequence[np.ndarray], free_weights: bool, ys: list[np.ndarray]
                ) -> tuple[list[LoopShapeFit], dict[str, tuple[Any, list[np.ndarray]]], int]:
    """Every loop-shape class fitted on the training rows and scored on ``rows``, best
    first; the fitted estimators and predictions by model; the thinning of the training
    rows (1: every row)."""
    shapes: list[LoopShapeFit] = []
    fitted: dict[str, tuple[Any, list[np.ndarray]]] = {}
    # long recordings: the classes are fitted on every k-th training row (the memory still
    # runs over every sample) and scored on every row of ``rows``
    n_tr = sum(int(m.sum()) for m in train)
    thin = max(1, -(-n_tr // MAX_SAMPLES))
    fit_rows = train if thin == 1 else [m & (np.arange(m.size) % thin == 0) for m in train]
    from ..fitting.metrics import percent_of_range

    for model, physics in loop_shape_kinds():
        try:
            est, pred = _fit_shape(model, records, fit_rows, rows, free_weights)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            continue
        es = np.concatenate([(r.y - p)[m] for r, p, m in zip(records, pred, rows,
                                                             strict=True)])
        r_ = float(np.sqrt(np.mean(es * es)))
        shapes.append(LoopShapeFit(model, physics, r_, percent_of_range(r_, ys),
                                   est.full_model_.to_dict()))
        fitted[model] = (est, pred)
    shapes.sort(key=lambda f: f.rmse)
    return shapes, fitted, thin


def _shape_words(records: Sequence[Recording], shapes: list[LoopShapeFit],
                 fitted: dict[str, tuple[Any, list[np.ndarray]]], rmse: float,
                 rate: bool = False, left: str = "") -> str:
    """What the loop-shape classes say about an inadequate final model of residual ``rmse``:
    the class that does clearly better, or that none does (and what the friction class
    finds), or that none could be fitted; ``rate``: the misfit grows with the recordings'
    rate (:func:`rate_trend`), which names where the cause lies; ``left``: what the
    recordings show that no rate-independent memory base follows
    (:meth:`core.fitting.physicsleft.PhysicsLeft.text`), said in every case."""
    from ..fitting.physicsleft import left_sentence

    also = left_sentence(left)
    better = [f for f in shapes if f.rmse < 0.8 * rmse]
    if better:
        b = better[0]
        return (f" The loop shape is the likely cause: {b.physics} reaches {b.pct:.2f} % of "
                f"range on the same rows (hyst fit --model {b.model}"
                + "".join(f"; {f.model} {f.pct:.2f} %" for f in shapes if f is not b) + ")"
                + _physics_of(records, *fitted[b.model]) + "." + also)
    if not shapes:
        return (" None of the other model classes (hyst fit --model "
                + ", ".join(k for k, _ in loop_shape_kinds())
                + ") could be fitted to these recordings." + also)
    text = (" No loop-shape class does clearly better (" + ", ".join(
        f"{f.model} {f.pct:.2f} %" for f in shapes) + "): the cause lies outside the "
        "models tried" + (", in the rate-dependence above (every class tried is "
                          "rate-independent)." if rate else
                          f"; the recordings show what it is: {left}." if left else
                          "; recordings that separate time, rate and level would tell."))
    if rate and left:
        text += also
    named = [f for f in shapes if getattr(fitted[f.model][0], "features_", None) is not None
             and fitted[f.model][0].features_.gap > 0]
    if named:  # the friction class still names what it found in these loops
        f = named[0]
        text += (f" The friction class (hyst fit --model {f.model}, {f.pct:.2f} % of range) "
                 "finds" + _physics_of(records, *fitted[f.model]).removeprefix(":") + ".")
    return text


def _physics_of(records: Sequence[Recording], est: Any, pred: Sequence[np.ndarray]) -> str:
    """What the better class found, in the recordings' units (a stop-operator fit's friction
    plateau and backlash gap), and what it leaves on the longest evenly sampled recording with a
    time axis (:func:`core.fitting.leftover.leftover`) and where its fast part peaks across the
    recordings (:func:`core.fitting.leftover.fast_across`); ``""`` when there is nothing to say."""
    from ..fitting.leftover import leftover_on

    out = ""
    feats = getattr(est, "features_", None)
    if feats is not None:
        units = records[0].units
        out += ": " + feats.text(units.get("input") or "input units",
                                 units.get("output") or "output units")
    flat = ("the sliding plateaus" if feats is not None
            else "the flat stretches of the branches")
    left = leftover_on(records, pred)
    if left.leftover is not None:
        out += f". With it, {left.leftover.text(flat)}"
    if left.across is not None:
        out += f"; {left.across.text(flat)}"
    return out
