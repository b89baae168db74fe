"""The base choice of ``hyst fit --model auto``: the diagnosis's rules on fit kinds.

``hyst diagnose`` chooses its base hysteresis before it judges any effect
(:mod:`core.diagnosis.engine`: the PI baseline's weight signs, then a Preisach and a
Bouc-Wen base cross-validated against it); :func:`choose_base` makes the same decisions
with the fit kinds' own estimators, on the training rows only (model selection never looks
at the held-out rows the report scores):

1. **Orientation and weight signs.** The PI family is fitted with non-negative weights in the
   orientation of the data's loops (plays for counter-clockwise loops, stop operators for
   clockwise ones: :func:`core.fitting.orientation.loop_orientation`) and with free-sign
   weights (``constraint="slopes"``: every branch slope positive, so a branch may flatten
   and rise again); free signs replace the sign rule when they lower the cross-validated
   MSE by at least :data:`FREE_SIGN_GAIN` (the diagnosis' "MSE at least halved").
2. **Preisach and Bouc-Wen bases**, only with two or more recordings (each predicted from
   the others: with one recording, blocks of it let a many-celled base interpolate; the
   diagnosis keeps the PI there too): a Preisach base replaces the PI when it lowers that
   MSE by :data:`PREISACH_MIN_GAIN` and beats the PI with a static output map (``mpi``) by
   :data:`PREISACH_OVER_MAP`; a Bouc-Wen base then replaces the chosen one when it lowers
   the PI's MSE by :data:`BW_MIN_GAIN` and by more than the Preisach did, and a
   Menegotto-Pinto bank (non-Masing loops, :mod:`core.fitting.nonmasing`) replaces the
   chosen one when it lowers the PI's MSE by :data:`MP_MIN_GAIN` and by more than the
   chosen one did.
3. **Loop shape.** With two or more recordings of counter-clockwise loops, the PI with a
   static output map (``mpi``: Kuhnen's modified PI) replaces the PI when it lowers the
   PI's MSE by :data:`PREISACH_MIN_GAIN` and the Preisach does not beat it by
   :data:`PREISACH_OVER_MAP` (nor the Bouc-Wen by more). This is the diagnosis's rule read
   the other way round: where a static map reconciles the loops, ``hyst diagnose`` keeps
   the PI base and its effect search names the map (``saturation``, ``asymmetry`` or
   ``dead-zone`` on the PI base: :mod:`core.diagnosis.shapes`); a fit has no effect search,
   so it fits the map itself. Measured on the shipped B-H loops (each loop predicted from
   the others): the map lowers the PI's MSE by 67-94 %, the Preisach beats the map by at
   most 13 %.
4. **Saturating play envelopes.** With two or more recordings of counter-clockwise loops, the
   generalized PI whose plays pass through a fitted saturating envelope (``gpi-tanh``: the
   loops saturate alike at every amplitude) replaces the chosen base when it lowers the
   chosen one's cross-validated MSE by :data:`PREISACH_OVER_MAP` (the margin a base needs
   over the map) and the PI's by :data:`PREISACH_MIN_GAIN` (nor the Bouc-Wen by more). Like
   the map, it is the PI base with a loop shape to ``hyst diagnose`` (family ``pi``).
   Measured on the shipped B-H loops, each started from the memory its cycle leaves
   (:mod:`core.fitting.steadystate`), each loop predicted from the others: it lowers the
   chosen base's MSE by 90 % (MnZn HP ferrite, against the Preisach) and 77 % (MnZn
   ferrite, against the map); on the grain-oriented steel it is 58 % worse than the map,
   which stays.

A candidate whose cross-validated fit fails or blows up (a non-finite MSE, or one above
:data:`BLOWN_UP` times the variance of the training output) is reported as failed
(:attr:`BaseChoice.failed`), never as a number, and never chosen.

On clockwise data the PI family is the ``stop-pi`` kind (stop operators: Maxwell-slip
elements behind the backlash gap its fit searches, whose report names the friction plateau
and the dead band); ``hyst diagnose`` judges its effects against the same base, with the
gap this fit finds (:mod:`core.diagnosis.bases`), and calls it by the same family name
(:func:`base_family`).

The margins are the diagnosis's: ``core.diagnosis.bases`` takes :data:`BW_MIN_GAIN` from
here and ``tests/core/fitting/test_choice.py`` checks the engine's own constants against
these. One difference: the diagnosis models output dynamics (a delay, a lag, a mode), so a
bank short of its margin gets a second look there with each base given its best output
stage (:class:`core.diagnosis.basechoice._EqualFooting`); the fit kinds have no such stage,
so on recordings a mode dominates the two commands may keep different bases.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..exceptions import NotInvertibleError, ParameterError
from ..recordings import Recording
from ..warning_filters import FILTERS
from .estimator import without_compensation_scores
from .orientation import LoopOrientation, loop_orientation
from .steadystate import SteadyStart

__all__ = ["AUTO", "BLOWN_UP", "BW_MIN_GAIN", "FAMILIES", "FREE_SIGN_GAIN", "MAP", "MP_MIN_GAIN",
           "PREISACH_MIN_GAIN", "PREISACH_OVER_MAP", "TANH", "BaseChoice", "base_family",
           "choose_base"]

#: The fit kind that asks for this choice.
AUTO = "auto"
#: Free-sign weights replace the sign rule when they lower the cross-validated MSE by this
#: share (the diagnosis's PI baseline: "MSE at least halved").
FREE_SIGN_GAIN = 0.5
#: A Preisach base replaces the PI when it lowers the MSE of predicting each recording from
#: the others by this share (``core.diagnosis.basechoice`` reads it) ...
PREISACH_MIN_GAIN = 0.2
#: ... and lowers it by this share against the PI with a static output map
#: (``core.diagnosis.basechoice`` reads it).
PREISACH_OVER_MAP = 0.3
#: A Bouc-Wen base replaces the chosen one when it lowers the PI's MSE by this share (and by
#: more than the Preisach did); measured on the diagnosis benchmark, see
#: :mod:`core.diagnosis.bases`.
BW_MIN_GAIN = 0.35
#: A Menegotto-Pinto base (non-Masing loops: :mod:`core.fitting.nonmasing`) replaces the
#: chosen one when it lowers the PI's MSE by this share and by more than the chosen base
#: did: the Bouc-Wen bank's margin (another bank of fixed-shape elements, linear in its
#: weights), shared with the diagnosis (:mod:`core.diagnosis.bases`); like the Preisach it
#: must also lower by PREISACH_OVER_MAP the MSE of the PI with a static output map or a
#: loop shape, where one was tried (the shipped ferrite: the bank -45 % against the PI, the
#: tanh envelope far better still).
MP_MIN_GAIN = BW_MIN_GAIN
#: A candidate's cross-validated MSE above this many times the variance of the training
#: output (an RMS error ten times the output's spread: worse than predicting its mean by
#: far) is a fit that blew up, reported as failed (the free-sign PI on the one shipped
#: amorphous-alloy loop: 1e28 T^2 against a variance of 0.5 T^2).
BLOWN_UP = 100.0
#: The score name of the PI with a static output map (the fit kind ``mpi``).
MAP = "mpi (static output map)"
#: The score name of the generalized PI with saturating play envelopes (fit kind ``gpi-tanh``).
TANH = "gpi-tanh (saturating play envelopes)"
#: Fit kind of each candidate's score name (what ``--model`` gets it), with the
#: constraint it was cross-validated with.
CANDIDATE_KINDS: dict[str, tuple[str, str]] = {
    "pi": ("pi", "nonnegative"), "pi (free-sign weights)": ("pi", "slopes"),
    "preisach": ("preisach", "nonnegative"), MAP: ("mpi", "nonnegative"),
    TANH: ("gpi-tanh", "nonnegative"), "bouc-wen": ("bouc-wen", "nonnegative"),
    "menegotto-pinto": ("menegotto-pinto", "nonnegative")}
#: Play operators of the PI candidates when the fit chooses its own (the diagnosis's
#: baseline default, ``hyst diagnose --operators``).
PI_OPERATORS = 25
#: Options of the candidates beyond the common keywords: the Bouc-Wen candidate keeps its
#: grid shapes unpolished, as the diagnosis's Bouc-Wen base does (a generic grid, weights by
#: least squares: :mod:`core.diagnosis.bases`); the chosen kind is then fitted in full.
CANDIDATE_OPTIONS: dict[str, dict[str, Any]] = {"bouc-wen": {"polish": False}}
#: Contiguous blocks of the training rows for the sign decision with one recording.
SIGN_BLOCKS = 3
#: The base family of each candidate fit kind, in the diagnosis's words
#: (:class:`core.diagnosis.results.BaseChoice` ``kind``): the stop-operator model behind a
#: backlash gap is the diagnosis's base of clockwise loops (``stop-pi``, fitted there with
#: the gap this module's fit finds: :func:`core.diagnosis.bases.fit_stop_gap`). The PI with
#: a static output map is the diagnosis's PI base with a loop shape that its effect search
#: names (module docstring, rule 3); so is the PI with saturating play envelopes (rule 4).
FAMILIES: dict[str, str] = {"pi": "pi", "stop-pi": "stop-pi", "preisach": "preisach",
                            "bouc-wen": "bouc-wen", "mpi": "pi", "gpi-tanh": "pi",
                            "menegotto-pinto": "menegotto-pinto"}


def base_family(kind: str) -> str:
    """The base family (:data:`FAMILIES`) of fit kind ``kind``: what ``hyst diagnose``'s base
    choice calls it."""
    return FAMILIES.get(kind, kind)


@dataclass(frozen=True)
class BaseChoice:
    """What :func:`choose_base` chose, and the numbers it chose on.

    Attributes
    ----------
    kind : str
        The chosen fit kind.
    constraint : str
        The constraint to fit it with (``"nonnegative"`` or ``"slopes"``).
    orientation : LoopOrientation
        The orientation of the training rows' loops.
    cv_mse : dict of str to float
        Cross-validated MSE (output units squared, finite) of each candidate tried that did
        not fail, on the training rows (``"pi"``, ``"pi (free-sign weights)"``,
        ``"preisach"``, :data:`MAP`, ``"bouc-wen"``).
    folds : str
        How the training rows were split.
    failed : tuple of str
        Candidates whose cross-validated fit failed or blew up (:data:`BLOWN_UP`).
    """

    kind: str
    constraint: str
    orientation: LoopOrientation
    cv_mse: dict[str, float] = field(default_factory=dict)
    folds: str = ""
    failed: tuple[str, ...] = ()

    @property
    def family(self) -> str:
        """The base family chosen (:func:`base_family`)."""
        return base_family(self.kind)

    @property
    def chosen_mse(self) -> float | None:
        """The chosen candidate's cross-validated MSE (``None`` if it was not scored)."""
        kind = "pi" if self.kind == "stop-pi" else self.kind
        for name, (k, c) in CANDIDATE_KINDS.items():
            if k == kind and (k != "pi" or c == self.constraint) and name in self.cv_mse:
                return self.cv_mse[name]
        # a constraint the user gave: the PI was scored with it, under the name "pi"
        return self.cv_mse.get("pi") if kind == "pi" else None

    @property
    def better(self) -> tuple[str, float] | None:
        """The tried candidate whose cross-validated MSE is lowest, with its gain over the
        chosen one's (a share), when that gain is at least :data:`PREISACH_MIN_GAIN` (the
        smallest margin a base choice counts as clearly better); else ``None``."""
        mine = self.chosen_mse
        if mine is None or not self.cv_mse:
            return None
        name = min(self.cv_mse, key=self.cv_mse.__getitem__)
        gain = 1.0 - self.cv_mse[name] / max(mine, 1e-300)
        return (name, gain) if gain >= PREISACH_MIN_GAIN else None

    @property
    def text(self) -> str:
        """The choice in words, for the fit report."""
        tried = ", ".join([f"{k} {v:.4g}" for k, v in self.cv_mse.items()]
                          + [f"{k} failed (its fit did not converge or blew up)"
                             for k in self.failed])
        how = "free-sign weights (every branch slope positive)" if self.constraint == "slopes" \
            else "the sign rule of the loops' orientation"
        what = {"mpi": f"{self.kind} (the PI with a static output map: the diagnosis keeps "
                       "the PI base and names the map as saturation, asymmetry or a dead zone)",
                "gpi-tanh": f"{self.kind} (the PI whose plays saturate through a fitted "
                            "envelope: the diagnosis keeps the PI base and names the "
                            "saturation)"}.get(self.kind, self.kind)
        return (f"base chosen as hyst diagnose chooses it: {what} with {how}, the loops "
                f"running {self.orientation.direction}; cross-validated MSE on the training "
                f"rows ({self.folds}): {tried}")

    @property
    def advice(self) -> str:
        """What to try when the chosen base misses the data: a tried candidate that predicted
        the recordings clearly better, by name and gain (and how to fit it), else what else
        to try."""
        better = self.better
        if better is not None:
            name, gain = better
            kind, constraint = CANDIDATE_KINDS.get(name, (name, "nonnegative"))
            how = f"--model {kind}" + (" --constraint slopes" if constraint == "slopes" else "")
            mine = self.chosen_mse
            return (f"Of the bases tried, {name} predicted the recordings {100 * gain:.0f} % "
                    f"better than the chosen {self.kind} (cross-validated MSE "
                    f"{self.cv_mse[name]:.4g} against {mine:.4g}) but was not chosen by the "
                    "diagnosis's margins; fit "
                    f"{how} to compare its held-out error")
        if len(self.cv_mse) + len(self.failed) > 2:  # other bases were cross-validated
            return ("No other base tried predicted the recordings clearly better (by "
                    f"{100 * PREISACH_MIN_GAIN:.0f} % of the cross-validated MSE); hyst "
                    "diagnose may name the missing effect")
        # (a Preisach model has counter-clockwise loops only)
        others = ["bouc-wen"] + ([] if self.orientation.clockwise
                                 else ["preisach", "mpi", "gpi-tanh"])
        if self.family != "pi":  # the stop base of clockwise loops, chosen on one recording
            return (f"With one recording only the {self.kind} base of these "
                    f"{self.orientation.direction} loops and the PI family are compared (as "
                    "hyst diagnose does: other bases cannot be cross-validated on it); fit "
                    f"--model {' or --model '.join(others)} to compare the held-out error, or "
                    "fit several recordings")
        return ("With one recording only the PI family is chosen (as hyst diagnose does: "
                "other bases cannot be cross-validated on it); fit --model "
                f"{' or --model '.join(others)} to compare the held-out error, or fit "
                "several recordings")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"kind": self.kind, "family": self.family, "constraint": self.constraint,
                "orientation": self.orientation.direction,
                "signed_loop_area": self.orientation.area, "cv_mse": dict(self.cv_mse),
                "failed": list(self.failed), "folds": self.folds}


def _folds(train: list[np.ndarray]) -> tuple[list[tuple[list[np.ndarray], list[np.ndarray]]],
                                            str]:
    """(fit rows, scored rows) per fold: each recording from the others, or with one
    recording :data:`SIGN_BLOCKS` contiguous blocks of its training rows."""
    have = [k for k, m in enumerate(train) if m.any()]
    none = [np.zeros(m.size, bool) for m in train]
    if len(have) >= 2:
        return ([([none[k] if k == j else m for k, m in enumerate(train)],
                  [m if k == j else none[k] for k, m in enumerate(train)]) for j in have],
                f"each of {len(have)} recordings predicted from the others")
    out = []
    for k in have:
        rows = np.flatnonzero(train[k])
        for block in np.array_split(rows, SIGN_BLOCKS):
            held = np.zeros(train[k].size, bool)
            held[block] = True
            fit = [m & ~held if j == k else m for j, m in enumerate(train)]
            score = [held if j == k else none[j] for j in range(len(train))]
            out.append((fit, score))
    return out, f"{SIGN_BLOCKS} contiguous blocks of the training rows, each held out in turn"


def _cv_mse(kind: str, constraint: str, recs: Sequence[Recording],
            folds: list[tuple[list[np.ndarray], list[np.ndarray]]],
            n_operators: int | None) -> float:
    """MSE of ``kind`` predicting each fold's scored rows from a fit on its other rows (the
    candidates' warnings are silenced: ``warnings.catch_warnings`` is process-wide, so
    callers in threads hold :data:`core.fitting.entry._WARNINGS_LOCK`, as
    :func:`~core.fitting.fit_recordings` does)."""
    from ..models import estimator_class

    cls = estimator_class(kind)
    us, ys = [r.u for r in recs], [r.y for r in recs]
    sse, n = 0.0, 0
    for fit_rows, score_rows in folds:
        use = [k for k, m in enumerate(fit_rows) if m.any()]
        est = cls(n_operators=n_operators, constraint=constraint, initial_memory="keep",
                  **CANDIDATE_OPTIONS.get(kind, {}))
        try:
            with FILTERS, warnings.catch_warnings(), without_compensation_scores():
                warnings.simplefilter("ignore")
                if len(use) > 1:
                    est.fit([us[k] for k in use], [ys[k] for k in use],
                            train=[fit_rows[k] for k in use])
                else:
                    est.fit(us[use[0]], ys[use[0]], train=fit_rows[use[0]])
        except (ParameterError, NotInvertibleError):  # (a fitted slope came out negative)
            return float("inf")
        for k, m in enumerate(score_rows):
            if m.any():
                e = ys[k][m] - np.asarray(est.predict(us[k]))[m]
                sse += float(e @ e)
                n += int(m.sum())
    return sse / n if n else float("inf")


def choose_base(
    recordings: Sequence[Recording],
    train: Sequence[np.ndarray] | None = None,
    test: Sequence[np.ndarray] | None = None,
    *,
    n_operators: int | None = None,
    constraint: str | None = None,
) -> BaseChoice:
    """Choose the base fit kind of recordings as the diagnosis does (module docstring).

    Parameters
    ----------
    recordings : sequence of Recording
        The recordings (``u``, ``y`` of shape ``(N_i,)``).
    train, test : sequence of bool ndarray of shape (N_i,), optional
        Training and held-out rows per recording (the fit's windows); without them the last
        20 % of every recording is held out, as the fit does. Only training rows are used.
        A recording in periodic steady state starts every candidate from the memory its
        own cycle leaves, as the fit does (:class:`core.fitting.steadystate.SteadyStart`).
    n_operators : int, optional
        Operators of every candidate (``None``: :data:`PI_OPERATORS` plays for the PI
        candidates, the other kinds' own defaults).
    constraint : {"nonnegative", "slopes"}, optional
        Given: the weight-sign decision is not made (only the base family is chosen).

    Returns
    -------
    BaseChoice
    """
    recs = list(recordings)
    start = SteadyStart.of(recs)
    trm, _ = start.rows(recs, list(train or []), list(test or []))
    if start.warm:  # each candidate starts as the fit does: from its cycle's memory
        recs, trm = start.padded(recs), start.pad_masks(trm)
    us, ys = [r.u for r in recs], [r.y for r in recs]
    orient = loop_orientation(us, ys, trm)
    folds, how = _folds(trm)
    y_train = np.concatenate([y[m] for y, m in zip(ys, trm, strict=True)])
    limit = BLOWN_UP * max(float(np.var(y_train)), 1e-300)
    scores: dict[str, float] = {}
    failed: list[str] = []

    def score(name: str, kind: str, sign: str, n: int | None) -> float:
        """The candidate's CV MSE, or ``inf`` (and ``name`` in ``failed``) when its fit
        failed or blew up."""
        mse = _cv_mse(kind, sign, recs, folds, n)
        if not (np.isfinite(mse) and mse <= limit):
            failed.append(name)
            return float("inf")
        scores[name] = mse
        return mse

    sign = constraint or "nonnegative"
    n_pi = n_operators or PI_OPERATORS
    base = score("pi", "pi", sign, n_pi)
    if constraint is None:
        free = score("pi (free-sign weights)", "pi", "slopes", n_pi)
        if free <= (1.0 - FREE_SIGN_GAIN) * base:
            sign, base = "slopes", free
    kind = "stop-pi" if orient.clockwise else "pi"
    if sum(m.any() for m in trm) >= 2 and np.isfinite(base):
        gain = 0.0  # the chosen replacement's gain over the PI
        mse_p = score("preisach", "preisach", "nonnegative", None)
        base = max(base, 1e-300)
        gain_p = 1.0 - mse_p / base
        # the map is cross-validated whenever it could replace the PI or decide the Preisach
        mse_map = (score(MAP, "mpi", "nonnegative", n_operators)
                   if gain_p >= PREISACH_MIN_GAIN or not orient.clockwise else float("inf"))
        gain_m = 1.0 - mse_map / base
        if gain_p >= PREISACH_MIN_GAIN and 1.0 - mse_p / max(mse_map, 1e-300) >= \
                PREISACH_OVER_MAP:
            kind, gain = "preisach", gain_p
        elif gain_m >= PREISACH_MIN_GAIN and not orient.clockwise:
            kind, gain = "mpi", gain_m  # (a play-based map: counter-clockwise loops only)
        mse_g = float("inf")
        if not orient.clockwise:  # (play envelopes: counter-clockwise loops only)
            mse_g = score(TANH, "gpi-tanh", "nonnegative", n_operators)
            chosen = {"preisach": mse_p, "mpi": mse_map}.get(kind, base)
            gain_g = 1.0 - mse_g / base
            if (gain_g >= PREISACH_MIN_GAIN
                    and 1.0 - mse_g / max(chosen, 1e-300) >= PREISACH_OVER_MAP):
                kind, gain = "gpi-tanh", gain_g
        mse_b = score("bouc-wen", "bouc-wen", "nonnegative", None)
        gain_b = 1.0 - mse_b / base
        if gain_b >= BW_MIN_GAIN and gain_b > gain:
            kind, gain = "bouc-wen", gain_b
        mse_mp = score("menegotto-pinto", "menegotto-pinto", "nonnegative", None)
        gain_mp = 1.0 - mse_mp / base
        # like the Preisach, it must also beat the PI with a static output map or a loop
        # shape where they were tried (the diagnosis's rule: basechoice._a_loop_shape_rivals)
        shapes = min(mse_map, mse_g)
        if (gain_mp >= MP_MIN_GAIN and gain_mp > gain
                and (not np.isfinite(shapes)
                     or 1.0 - mse_mp / max(shapes, 1e-300) >= PREISACH_OVER_MAP)):
            kind = "menegotto-pinto"
    if kind in ("preisach", "bouc-wen", "mpi", "gpi-tanh", "menegotto-pinto"):
        sign = "nonnegative"
    return BaseChoice(kind, sign, orient, scores, how, tuple(failed))
