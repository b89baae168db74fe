"""Identification of the classical PI model: :class:`PIRegressor`.

Model fitted::

    y(t) ≈ c + p0·u(t) + Σ_i p_i Γ_{r_i}[u](t),    p0 >= ε > 0,  p_i >= 0

With ``p0 > 0`` and every ``p_i >= 0`` all loop-segment slopes ``p0 + p_1 + ... + p_k`` are
positive, so the fitted model is **always invertible** (paper 001 eq. 33-37). The weights
come from non-negative least squares on the column-scaled Cholesky factor of the streamed
Gram matrix (:mod:`core.fitting.gram`), the offset ``c`` is a free parameter eliminated
exactly in the triangular factor, and ``p0 >= ε`` is handled by a shift of variables.

Initial state: each recording starts with every play operator relaxed at the first input
sample, ``z_i(0) = u[0]`` (as if the input had rested at ``u[0]``), both in ``fit`` and in
``predict``. A recording whose true history is unknown should start with a rest period, or
its first samples should be excluded from the loss with the ``train=`` mask: excluded
samples still drive the operator states, so the memory is right when scoring starts.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._typing import ArrayLike, Float1D
from ..base import Chain
from ..exceptions import FitWarning, ParameterError
from ..pi import PIModel
from ..stages import Offset
from ..validation import as_vector, filled
from ._data import (
    INITIAL_MEMORY_RULES,
    Prepared,
    as_recordings,
    exclude_before_wipeout,
    prepare,
)
from .estimator import Estimator
from .gram import COND_LIMIT, DEFAULT_CHUNK, Segment, solve_constrained, stream_gram, stream_tsqr
from .orientation import LoopOrientation, loop_orientation
from .thresholds import place_thresholds

__all__ = ["DEFAULT_CANDIDATES", "LinearPIFit", "PIRegressor", "cv_choice_note", "fit_linear_pi"]

#: Numbers of operators tried when ``n_operators=None``.
DEFAULT_CANDIDATES: tuple[int, ...] = (5, 10, 15, 20, 25, 30, 40)


@dataclass(frozen=True, eq=False)
class LinearPIFit:
    """Result of :func:`fit_linear_pi`.

    Attributes
    ----------
    offset : float
        Output offset ``c`` (0 when not fitted).
    p0 : float
        Linear weight.
    weights : ndarray of shape (n,)
        Play weights.
    extra : ndarray of shape (k,)
        Weights of the extra memoryless columns.
    sse : float
        Training residual sum of squares.
    cond : float
        Condition number of the column-scaled Gram matrix.
    solver : str
    """

    offset: float
    p0: float
    weights: Float1D
    extra: Float1D
    sse: float
    cond: float
    solver: str


def fit_linear_pi(
    segments: Sequence[Segment],
    thresholds: Float1D,
    *,
    min_slope: float,
    include_offset: bool = True,
    train_labels: Sequence[int] = (0,),
    gram: np.ndarray | None = None,
    transform: Callable[[Float1D], Float1D] | None = None,
    extra: Callable[[Float1D, Float1D, Float1D | None], np.ndarray] | None = None,
    extra_lower: Float1D | None = None,
    chunk: int = DEFAULT_CHUNK,
    allow_tsqr: bool = True,
    constraint: str = "nonnegative",
) -> LinearPIFit:
    """Constrained least-squares weights of ``c + p0 x + Σ p_i Γ_{r_i}[x] + Σ e_j E_j``.

    Parameters
    ----------
    segments : sequence of Segment
        Labelled recordings.
    thresholds : ndarray of shape (n,)
        Play thresholds (units of ``x``).
    min_slope : float
        Lower bound ε > 0 of ``p0``.
    include_offset : bool
        Fit a free output offset ``c``.
    train_labels : sequence of int
        Labels summed into the training Gram matrix.
    gram : ndarray of shape (L, m, m), optional
        Pre-computed per-label Gram matrices from :func:`stream_gram` (same arguments).
    transform, extra : callable, optional
        See :func:`core.fitting.gram.stream_gram`.
    extra_lower : ndarray of shape (k,), optional
        Lower bounds of the extra weights (``-inf`` = free); required with ``extra``.
    chunk : int
        Samples per chunk.
    allow_tsqr : bool
        Recompute the factor by TSQR when the scaled Gram matrix is ill conditioned.
    constraint : {"slopes", "nonnegative", "stop"}
        Invertibility constraint, see :func:`constraint_transform`.

    Returns
    -------
    LinearPIFit
    """
    r = np.asarray(thresholds, dtype=np.float64)
    n = r.size
    xl = np.zeros(0) if extra_lower is None else np.asarray(extra_lower, dtype=np.float64)
    k = xl.size
    if gram is None:
        n_lab = int(max(train_labels)) + 1
        gram = stream_gram(segments, r, n_labels=n_lab, transform=transform, extra=extra,
                           n_extra=k, chunk=chunk)
    G = np.sum(gram[list(train_labels)], axis=0)
    T, lower = constraint_transform(n, k, min_slope, constraint)
    lower[2 + n :] = xl
    keep = np.ones(lower.size + 1, dtype=bool)
    if not include_offset:
        keep[0] = False
    Tk = T[np.ix_(keep, keep)]
    sol = solve_constrained(lower[keep[:-1]], gram=Tk.T @ G[np.ix_(keep, keep)] @ Tk)
    solver = "gram-cholesky-nnls"
    if sol.cond > COND_LIMIT and allow_tsqr:
        R = stream_tsqr(segments, r, use_labels=train_labels, transform=transform, extra=extra,
                        n_extra=k, chunk=chunk)
        sol = solve_constrained(lower[keep[:-1]], factor=R[np.ix_(keep, keep)] @ Tk)
        solver = "tsqr-nnls"
    theta = np.zeros(lower.size)
    theta[keep[:-1]] = sol.theta
    theta = T[:-1, :-1] @ theta
    return LinearPIFit(
        offset=float(theta[0]),
        p0=float(theta[1]),
        weights=theta[2 : 2 + n].copy(),
        extra=theta[2 + n :].copy(),
        sse=sol.sse,
        cond=sol.cond,
        solver=solver,
    )


def constraint_transform(
    n: int, k: int, min_slope: float, constraint: str
) -> tuple[np.ndarray, Float1D]:
    """Change of variables and lower bounds that make the fitted PI model invertible.

    The design columns are ``[1, x, z_1..z_n, E_1..E_k, y]`` with parameters
    ``θ = (c, p0, p_1..p_n, e_1..e_k)``. The fit solves for ``φ`` with ``θ = T φ`` under
    ``φ >= lower`` (the Gram matrix becomes ``Tᵀ G T``).

    ``"slopes"``
        ``φ`` holds the loop-segment slopes ``S_0 = p0, S_j = p0 + p_1 + ... + p_j``, all
        bounded below by ε: exactly the invertibility condition of paper 001 (eq. 33-37).
        Weights may be negative, so saturating (concave) loading curves such as B-H loops
        or friction are representable, and the inverse slope never exceeds ``1/ε``.
    ``"nonnegative"`` (default of :class:`PIRegressor`)
        ``p0 >= ε`` and ``p_i >= 0``: the classical sufficient condition (slopes only grow
        along a branch: hardening / convex loading curves, as in piezo actuators).
    ``"stop"``
        ``φ`` holds ``(c, k, w_1..w_n)`` of stop operators, ``p0 = k + Σ w_i``,
        ``p_i = -w_i``, with ``k >= ε`` and ``w_i >= 0``: slopes only fall along a branch
        (softening / concave loading curves, clockwise loops: friction, stress-strain),
        the last one ``k``. What ``"nonnegative"`` becomes on clockwise data.

    Parameters
    ----------
    n, k : int
        Numbers of play operators and extra columns.
    min_slope : float
        ε > 0.
    constraint : {"slopes", "nonnegative", "stop"}

    Returns
    -------
    T : ndarray of shape (n + k + 3, n + k + 3)
        Column transformation (the last row/column, for ``y``, is the identity).
    lower : ndarray of shape (n + k + 2,)
        Lower bounds of ``φ`` (``-inf`` = free).
    """
    m = n + k + 3
    T = np.eye(m)
    if constraint == "slopes":
        # p_i = S_i - S_{i-1} for i = 1..n (rows/columns 2..n+1; p0 = S_0 is column 1)
        for i in range(2, n + 2):
            T[i, i - 1] = -1.0
        lower = np.concatenate(([-np.inf], np.full(n + 1, min_slope), np.full(k, -np.inf)))
    elif constraint == "nonnegative":
        lower = np.concatenate(([-np.inf, min_slope], np.zeros(n), np.full(k, -np.inf)))
    elif constraint == "stop":
        # φ = (c, k, w_1..w_n): p0 = k + Σ w_i, p_i = -w_i (stop operators Ξ_r = I - Γ_r)
        T[1, 2 : n + 2] = 1.0
        for i in range(2, n + 2):
            T[i, i] = -1.0
        lower = np.concatenate(([-np.inf, min_slope], np.zeros(n), np.full(k, -np.inf)))
    else:
        raise ParameterError(
            f"constraint must be 'slopes' or 'nonnegative', got {constraint!r}"
        )
    return T, lower


def _cv_sse(gram: np.ndarray, n_blocks: int, lower: Float1D, T: np.ndarray) -> float:
    """Blocked cross-validation: fit on all blocks but one, score the left-out block.

    ``gram`` holds per-label Gram matrices (already restricted to the kept columns) and
    ``T`` the constraint transform; labels ``0..n_blocks-1`` are the blocks.
    """
    total = 0.0
    # (T^T G_b T for every block as a batched product: O(m^3) each; the same contraction
    # written as one einsum ran as a 4-deep loop, O(m^4), 1.4 s of a 100-operator CV)
    Gs = T.T @ gram[:n_blocks] @ T
    G_all = Gs.sum(axis=0)
    for b in range(n_blocks):
        sol = solve_constrained(lower, gram=G_all - Gs[b])
        v = np.concatenate((sol.theta, [-1.0]))
        total += float(v @ Gs[b] @ v)
    return total


def cv_choice_note(scores: dict[int, float | None], n: int, tolerance: float) -> str:
    """What the cross-validation chose, in words for the fit report: ``n`` among the tried
    numbers of operators (``scores``: number -> CV RMSE, ``None`` where too few samples),
    and, when ``n`` is the largest tried and its RMSE still fell by more than ``tolerance``
    (relative) from the next smaller one, that more operators may fit better."""
    valid = sorted(k for k, v in scores.items() if v is not None)
    if not valid:
        return f"n = {n} operators: too few training samples to cross-validate the choice"
    text = f"n = {n} operators chosen by cross-validation among {', '.join(map(str, valid))}"
    if n == valid[-1] and len(valid) > 1:
        prev, last = scores[valid[-2]], scores[n]
        assert prev is not None and last is not None
        if last < (1 - tolerance) * prev:
            text += (f"; the largest tried, and its error was still falling (RMSE {prev:.4g} "
                     f"at {valid[-2]}, {last:.4g} at {n}): more operators ({3 * n // 2} or "
                     "more) may fit better")
    return text


@dataclass(frozen=True, eq=False)
class _Design:
    """The weight fit's design: ``n`` thresholds, the Gram matrices over ``segments`` of
    the labels trained on (none of the held-out label, which is scored by simulation) and
    the labels trained and tested on."""

    n: int
    thresholds: Float1D
    gram: np.ndarray
    segments: list[Segment]
    train_labels: tuple[int, ...]
    test_label: int


@dataclass(eq=False, repr=False)
class PIRegressor(Estimator):
    """Fit an invertible classical PI model (plus output offset) to input/output records.

    Parameters
    ----------
    n_operators : int, optional
        Number of play operators. ``None`` chooses it from ``candidates`` by blocked
        cross-validation on the training samples: the smallest ``n`` whose CV RMSE is
        within ``tolerance`` (2 %) of the best.
    thresholds : {"uniform", "quantile"} or array_like of shape (n,)
        Threshold placement rule (:func:`core.fitting.thresholds.place_thresholds`) or
        explicit increasing thresholds (input units; then ``n_operators`` is their number).
    r_max : float, optional
        Widest threshold (input units); default 0.9 × the largest half-travel between
        reversals.
    include_offset : bool
        Fit a free output offset ``c`` (output units), stored in ``offset_``.
    validation : float
        Fraction at the end of every recording held out for the report when ``fit`` gets
        no ``train``/``test`` masks.
    min_slope : float, optional
        Lower bound ε of the constrained slopes (output per input unit); default 1e-3 ×
        output range / input range. It bounds the inverse's slopes by ``1/ε``.
    candidates : sequence of int
        Values of ``n`` tried when ``n_operators`` is None.
    cv_blocks : int
        Number of contiguous blocks for cross-validation.
    tolerance : float
        Relative CV-RMSE tolerance for picking the smallest adequate ``n``.
    chunk : int
        Samples per streaming chunk.
    constraint : {"nonnegative", "slopes"}
        ``"nonnegative"`` (default): ``p0 >= ε`` and ``p_i >= 0`` (hardening loops, e.g.
        piezo actuators); ``"slopes"``: every loop-segment slope ``p0 + p_1 + ... + p_j >= ε``
        (the exact invertibility condition; weights may be negative, so saturating loops
        such as B-H curves or friction fit).
    initial_memory : {"exclude", "keep"}
        The play states at the start of a recording are unknown (a recording that starts in
        the middle of the actuator's history), and only the rows before the wipe-out time
        (:func:`core.fitting.thresholds.wipeout_index`: the input has reached both ends of
        its range) depend on them. ``"exclude"`` (``hyst fit``'s default) leaves those
        training rows out of the weight fit when at least a third of the training rows
        remain (they still drive the operator states); ``"keep"`` (default here, for
        recordings known to start relaxed, e.g. simulated ones) fits every training row from
        the relaxed state. ``report_.extra["initial_memory"]`` says what was done.

    Attributes
    ----------
    model_ : PIModel
        Fitted model (without offset); ``state0`` is relaxed at the first training
        recording's first input sample.
    offset_ : float
        Output offset; predictions are ``model_(u) + offset_``.
    full_model_ : Chain
        ``model_ >> Offset(offset_)``: serialisable (``to_dict``) and exactly invertible;
        it reproduces ``predict`` for the first training recording's initial state.
    p0_, weights_, thresholds_ : float, ndarray of shape (n,), ndarray of shape (n,)
    n_operators_ : int
    cv_scores_ : dict of int to float or None
        Cross-validation RMSE per candidate ``n`` (output units), when ``n`` was chosen.
    report_ : FitReport

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 3, 3000)
    >>> u = 2 * np.sin(2 * np.pi * t)
    >>> true = PIModel(0.5, [0.4, 0.8, 1.2], [0.3, 0.2, 0.1])
    >>> est = PIRegressor(thresholds=[0.4, 0.8, 1.2]).fit(u, true(u) + 1.0)
    >>> round(est.offset_, 6), np.round(est.weights_, 6).tolist()
    (1.0, [0.3, 0.2, 0.1])
    """

    #: Both rules: the pre-wipe-out rows can be left out of the weight fit.
    initial_memory_rules: ClassVar[tuple[str, ...]] = INITIAL_MEMORY_RULES
    #: Whether ``fit`` scores the fit into ``report_`` (the model simulated, inverted and
    #: simulated again over every record); off only for the weight fits inside the stop
    #: model's gap search, of which only the model and offset are read
    #: (:mod:`core.fitting.stop`).
    scores_fit: ClassVar[bool] = True

    n_operators: int | None = None
    thresholds: str | ArrayLike = "uniform"
    r_max: float | None = None
    include_offset: bool = True
    validation: float = 0.2
    min_slope: float | None = None
    candidates: Sequence[int] = DEFAULT_CANDIDATES
    cv_blocks: int = 5
    tolerance: float = 0.02
    chunk: int = DEFAULT_CHUNK
    constraint: str = "nonnegative"
    initial_memory: str = "keep"

    @classmethod
    def classical_start(cls, est: Any, **options: Any) -> PIRegressor:
        """The classical fit an estimator built on it starts from (the GPIs, the digitized
        fit): ``est``'s shared options (``n_operators``, ``thresholds``, ``include_offset``,
        ``min_slope``, ``constraint``, ``chunk``) and ``options``."""
        return cls(n_operators=est.n_operators, thresholds=est.thresholds,
                   include_offset=est.include_offset, min_slope=est.min_slope,
                   constraint=est.constraint, chunk=est.chunk, **options)

    # ------------------------------------------------------------------ helpers
    def _thresholds_for(self, prep: Prepared, n: int) -> Float1D:
        if isinstance(self.thresholds, str):
            return place_thresholds(prep.us, n, self.thresholds, self.r_max)
        return as_vector(self.thresholds, "thresholds", positive=True, increasing=True)

    def _orientation(self, prep: Prepared) -> LoopOrientation:
        """The loops' orientation on the training rows (:func:`loop_orientation`), which
        the constraint (:meth:`_constraint_for`) and the report's line read."""
        return loop_orientation(prep.us, prep.ys, prep.train_masks)

    def _constraint_for(self, orientation: LoopOrientation) -> str:
        """The constraint the weights are solved under: ``"nonnegative"`` becomes
        ``"stop"`` on clockwise loops (:func:`constraint_transform`)."""
        if self.constraint == "nonnegative" and orientation.clockwise:
            return "stop"
        if self.constraint not in ("nonnegative", "slopes"):
            raise ParameterError(
                f"constraint must be 'slopes' or 'nonnegative', got {self.constraint!r}")
        return str(self.constraint)

    def _lower(self, n: int, eps: float) -> tuple[Float1D, np.ndarray, np.ndarray]:
        T, lower = constraint_transform(n, 0, eps, self.constraint_)
        keep = np.ones(n + 3, dtype=bool)
        keep[0] = bool(self.include_offset)
        return lower[keep[:-1]], keep, T[np.ix_(keep, keep)]

    # ------------------------------------------------------------------ API
    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Fit thresholds (by rule), weights and offset (the work of :meth:`fit`).

        Raises
        ------
        ParameterError
            Bad inputs (see :meth:`fit`) or thresholds.

        Warns
        -----
        FitWarning
            When a slope sits on its lower bound (the inverse is very steep there) or the
            design is nearly collinear.
        """
        n_fixed, r_exp = self._fixed_size()
        n_min = n_fixed if n_fixed is not None else min(self.candidates)
        prep = prepare(
            u, y, train, test, validation=self.validation, min_train=max(20, 3 * (n_min + 3))
        )
        prep_all = prep
        prep, memory_note = exclude_before_wipeout(prep, self.initial_memory)
        self.orientation_ = self._orientation(prep)
        self.constraint_ = self._constraint_for(self.orientation_)
        eps = self._min_slope(prep)
        cv_scores: dict[int, float | None] = {}
        design = None
        if n_fixed is None:
            cv_scores, design = self._cross_validate(prep, eps)
            if design is None:  # too few samples to cross-validate: smallest candidate, no CV
                n_fixed = min(int(c) for c in self.candidates)
                warnings.warn(
                    f"only {prep.n_train} training samples: too few for {int(self.cv_blocks)}"
                    f"-block cross-validation, using n_operators = {n_fixed}",
                    FitWarning,
                    stacklevel=3,
                )
        if design is None:
            n = int(filled(n_fixed))  # set where no candidate could be cross-validated
            segs = prep.segments(1)
            r = r_exp if r_exp is not None else self._thresholds_for(prep, n)
            # the training rows' Gram only (label 0): the weights are solved on it, the
            # held-out rows (label 1) are scored by simulation, never from a Gram matrix
            design = _Design(n, r, stream_gram(segs, r, n_labels=1, chunk=self.chunk), segs,
                             (0,), 1)
        n, r = design.n, design.thresholds
        fit = fit_linear_pi(
            design.segments,
            r,
            min_slope=eps,
            include_offset=self.include_offset,
            train_labels=design.train_labels,
            gram=design.gram,
            chunk=self.chunk,
            constraint=self.constraint_,
        )
        self._warn_fit(fit, eps)
        self.thresholds_ = np.asarray(r, dtype=np.float64)
        self.p0_ = fit.p0
        self.weights_ = fit.weights
        self.offset_ = fit.offset
        self.n_operators_ = n
        self.cv_scores_ = cv_scores
        self.min_slope_ = eps
        self.model_ = self._build(fit.p0, r, fit.weights, float(prep.us[0][0]))
        self.full_model_ = Chain.of(self.model_, Offset(self.offset_))
        if not self.scores_fit:
            return
        # scored on the whole training window (rows before the wipe-out time included, when
        # they were left out of the weight fit)
        ev_segs, ev_train, ev_test = (
            (design.segments, design.train_labels, design.test_label) if prep is prep_all
            else (prep_all.segments(1), (0,), 1))
        self.report_ = self._scored_report(
            ev_segs,
            train_labels=ev_train,
            test_labels=(ev_test,),
            model_type=self.model_.type_name,
            n_parameters=n + 1 + int(self.include_offset),
            invertible=self.model_.is_invertible,
            min_slope=float(np.min(self.model_.slopes)),
            condition_number=fit.cond,
            solver=fit.solver,
            extra=self._report_extra(n, eps, fit, cv_scores, memory_note),
        )

    def _fixed_size(self) -> tuple[int | None, Float1D | None]:
        """The number of operators when it is not chosen by cross-validation (``None``
        otherwise), and the explicit thresholds when they were given."""
        n_fixed = self.n_operators
        r_exp = None
        if not isinstance(self.thresholds, str):
            r_exp = as_vector(self.thresholds, "thresholds", positive=True, increasing=True)
            if n_fixed is not None and n_fixed != r_exp.size:
                raise ParameterError(
                    f"n_operators = {n_fixed} but {r_exp.size} explicit thresholds were given"
                )
            n_fixed = r_exp.size
        if n_fixed is not None and (int(n_fixed) != n_fixed or n_fixed < 1):
            raise ParameterError(f"n_operators must be a positive integer, got {n_fixed!r}")
        return n_fixed, r_exp

    def _cross_validate(self, prep: Prepared, eps: float
                        ) -> tuple[dict[int, float | None], _Design | None]:
        """Blocked cross-validation over ``candidates``: the RMSE of each (``None`` where
        too few samples) and the design of the chosen number (the smallest within
        ``tolerance`` of the best), or ``None`` when no candidate could be scored."""
        K = int(self.cv_blocks)
        segs = prep.segments(K)
        cv_scores: dict[int, float | None] = {}
        results = {}
        for n in sorted(set(int(c) for c in self.candidates)):
            if prep.n_train < 3 * (n + 3) * K // (K - 1):
                cv_scores[n] = None
                continue
            r = self._thresholds_for(prep, n)
            gram = stream_gram(segs, r, n_labels=K, chunk=self.chunk)  # (not the held-out K)
            lower, keep, T = self._lower(n, eps)
            sse = _cv_sse(gram[:, keep][:, :, keep], K, lower, T)
            cv_scores[n] = float(np.sqrt(sse / prep.n_train))
            results[n] = (r, gram)
        valid = {n: s for n, s in cv_scores.items() if s is not None}
        if not valid:
            return cv_scores, None
        best_score = min(valid.values())
        n = min(n for n, s in valid.items() if s <= (1 + self.tolerance) * best_score)
        r, gram = results[n]
        return cv_scores, _Design(n, r, gram, segs, tuple(range(K)), K)

    @staticmethod
    def _warn_fit(fit: LinearPIFit, eps: float) -> None:
        """Warn of a nearly collinear design and of a slope on its lower bound."""
        if fit.cond > COND_LIMIT:
            warnings.warn(
                f"nearly collinear design (cond = {fit.cond:.2g}): some thresholds may exceed "
                "the input travel of the data, so their operators never move",
                FitWarning,
                stacklevel=4,
            )
        slopes = np.cumsum(np.concatenate(([fit.p0], fit.weights)))
        if float(slopes.min()) <= eps * (1 + 1e-9):
            j = int(np.argmin(slopes))
            warnings.warn(
                f"loop slope S{j + 1} sits on its lower bound min_slope = {eps:.3g}: the fitted "
                f"model is invertible but its inverse has slope up to {1 / eps:.3g} (input per "
                "output unit); consider a larger min_slope if the inverse drives an actuator",
                FitWarning,
                stacklevel=4,
            )

    def _report_extra(self, n: int, eps: float, fit: LinearPIFit,
                      cv_scores: dict[int, float | None], memory_note: Any) -> dict[str, Any]:
        """The kind's numbers of the report (``FitReport.extra``)."""
        extra: dict[str, Any] = {"n_operators": n, "min_slope": eps, "offset": fit.offset}
        if cv_scores:
            extra["cv_rmse"] = cv_scores
            extra["cv_choice"] = cv_choice_note(cv_scores, n, self.tolerance)
        extra["initial_memory"] = memory_note
        extra["orientation"] = self.orientation_.text + {
            "stop": "; fitted with stop operators (Maxwell-slip elements)",
            "nonnegative": "; fitted with play operators, non-negative weights",
            "slopes": "; fitted with weights of either sign, every branch slope positive",
        }[self.constraint_]
        extra["constraint"] = self.constraint_
        extra.update(self._extra())
        return extra

    def _build(self, p0: float, r: Float1D, w: Float1D, u0: float) -> Any:
        """The fitted model of weights ``(p0, w)`` on thresholds ``r``, relaxed at ``u0``."""
        return PIModel(p0, r, w, np.full(r.size, u0))

    def _extra(self) -> dict[str, Any]:
        """Kind-specific numbers of the report (none for the PI)."""
        return {}

    def _model_for(self, u: Float1D) -> Any:
        m = self.model_
        return type(m).from_dict({**m.to_dict(), "state0": np.full(m.n, float(u[0]))})

    def compensate(self, y_desired: ArrayLike) -> Float1D:
        """Feed-forward command ``u = M⁻¹(y_desired - offset_)`` from the exact inverse.

        The inverse starts consistently with the forward model relaxed at
        ``M⁻¹``'s first output, so ``predict(compensate(y_d)) == y_d`` to round-off.

        Parameters
        ----------
        y_desired : array_like of shape (N,)
            Desired output (output units).

        Returns
        -------
        ndarray of shape (N,)
            Input command (input units).
        """
        self._check()
        yd = np.asarray(as_recordings(y_desired, "y_desired")[0][0]) - self.offset_
        if yd.size == 0:
            return yd
        S = float(self.model_.slopes[-1])
        u0 = float(yd[0]) / S
        return self._model_for(np.array([u0])).inverse()(yd)
