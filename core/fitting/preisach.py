"""Identification of the level-dependent Preisach model: :class:`PreisachRegressor`.

Model fitted (:class:`core.preisach.PreisachModel` plus an output offset)::

    y(t) ≈ c + Σ_{i=0..n} Σ_{j<m} W[i, j] seg_j(Γ_{r_i}[u](t)),   r_0 = 0,
    W[0, j] >= ε > 0,   W[i, j] >= 0 (i >= 1)

Once the thresholds ``r_i`` and the level knots ``e_j`` are placed, the model is linear in
``W`` and ``c``: the design columns ``seg_j(z_i)`` are streamed chunk by chunk into the Gram
matrix (play states carried across chunks) and the weights come from the bounded least
squares of :func:`core.fitting.gram.solve_constrained`. ``W[0, :] >= ε`` (the reversible
slope on every level segment, ε as :func:`core.fitting.estimator.default_min_slope`) makes every
fitted model invertible. A column that never changes on the training rows (a wide play whose
output never reaches an outer level segment) cannot be told from the offset; its weight is
fixed to 0 (``ε`` for the reversible play).

Initial state: as :class:`~core.fitting.pi.PIRegressor`, every play starts relaxed at the
first input sample of each recording, in ``fit`` and in ``predict``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .. import kernels
from .._typing import ArrayLike, Float1D
from ..base import Chain
from ..exceptions import FitWarning, ParameterError
from ..preisach import PreisachModel, level_segments
from ..stages import Offset
from ..validation import as_vector
from ._data import INITIAL_MEMORY_RULES, Prepared, exclude_before_wipeout, prepare
from .estimator import Estimator
from .gram import COND_LIMIT, DEFAULT_CHUNK, Segment, solve_constrained
from .orientation import loop_orientation
from .thresholds import place_thresholds

__all__ = ["PreisachRegressor", "place_knots", "stream_level_gram"]


def place_knots(prep: Prepared, m: int, rule: str = "uniform") -> Float1D:
    """``m - 1`` interior level knots over the training input range.

    Parameters
    ----------
    prep : Prepared
        Recordings with training masks.
    m : int
        Number of level segments, ``m >= 1``.
    rule : {"uniform", "quantile"}
        Equal spacing over ``[min u, max u]`` of the training rows, or the quantiles
        ``j / m`` of the training inputs.

    Returns
    -------
    ndarray of shape (m - 1,)
        Strictly increasing knots (input units).

    Raises
    ------
    ParameterError
        For an unknown rule or quantiles that coincide (an input resting at few values).
    """
    u = np.concatenate([x[t] for x, t in zip(prep.us, prep.train_masks, strict=True)])
    q = np.arange(1, m) / m
    if rule == "uniform":
        lo, hi = float(u.min()), float(u.max())
        return lo + (hi - lo) * q
    if rule == "quantile":
        e = np.quantile(u, q)
        if e.size > 1 and (np.diff(e) <= 0).any():
            raise ParameterError(
                f"knots='quantile' gives repeated knots {np.round(e, 6).tolist()} (the input "
                "rests at a few values); use knots='uniform' or fewer n_levels"
            )
        return e
    raise ParameterError(
        f"knots must be 'uniform', 'quantile' or an array of increasing values, got {rule!r}"
    )


def stream_level_gram(
    segments: Sequence[Segment],
    thresholds: Float1D,
    knots: Float1D,
    *,
    n_labels: int = 2,
    chunk: int = DEFAULT_CHUNK,
) -> tuple[np.ndarray, Float1D]:
    """Augmented Gram matrices of the columns ``[1, seg_j(z_i) ..., y]`` per label.

    Parameters
    ----------
    segments : sequence of Segment
        Labelled recordings (``z0=None``: plays relaxed at the first input sample).
    thresholds : ndarray of shape (n,)
    knots : ndarray of shape (m - 1,)
    n_labels : int
        Gram matrices for labels ``0..n_labels-1`` (other labels only advance the plays).
    chunk : int
        Samples per chunk.

    Returns
    -------
    gram : ndarray of shape (n_labels, p + 1, p + 1)
        With ``p = 1 + n m`` and the level column of ``(i, j)`` at ``1 + i m + j``.
    spread : ndarray of shape (p,)
        ``max - min`` of every column on the label-0 rows (0 for a constant column).
    """
    r = np.ascontiguousarray(thresholds, dtype=np.float64)
    e = np.ascontiguousarray(knots, dtype=np.float64)
    n, m = r.size, e.size + 1
    p = 1 + n * m
    G = np.zeros((n_labels, p + 1, p + 1))
    lo = np.full(p, np.inf)
    hi = np.full(p, -np.inf)
    zbuf = np.empty((chunk, n))
    abuf = np.empty((chunk, p + 1))
    for seg in segments:
        z = None
        for s0 in range(0, seg.u.size, chunk):
            s1 = min(seg.u.size, s0 + chunk)
            c = s1 - s0
            uc = seg.u[s0:s1]
            if z is None:
                z = np.full(n, float(uc[0])) if seg.z0 is None else np.array(seg.z0, copy=True)
            Z = zbuf[:c]
            kernels.play_matrix(uc, r, z, Z)
            A = abuf[:c]
            A[:, 0] = 1.0
            A[:, 1:p] = level_segments(Z.ravel(), e).reshape(c, n * m)
            A[:, p] = seg.y[s0:s1]
            lab = np.zeros(c, dtype=np.int8) if seg.labels is None else seg.labels[s0:s1]
            for g in range(n_labels):
                sel = lab == g
                if not sel.any():
                    continue
                As = A[sel]
                G[g] += As.T @ As
                if g == 0:
                    lo = np.minimum(lo, As[:, :p].min(axis=0))
                    hi = np.maximum(hi, As[:, :p].max(axis=0))
    spread = np.where(np.isfinite(hi - lo), hi - lo, 0.0)
    return G, spread


def _positive_int(v: Any, name: str) -> int:
    if isinstance(v, bool) or int(v) != v or v < 1:
        raise ParameterError(f"{name} must be a positive integer, got {v!r}")
    return int(v)


@dataclass(eq=False, repr=False)
class PreisachRegressor(Estimator):
    """Fit an invertible level-dependent Preisach model (plus output offset).

    Parameters
    ----------
    n_thresholds : int
        Number of play thresholds ``r > 0`` (the reversible ``r_0 = 0`` play is added, so
        the model has ``n_thresholds + 1`` plays).
    n_levels : int
        Number of level segments ``m`` (``m - 1`` interior knots); 1 fits a PI model.
    thresholds : {"uniform", "quantile"} or array_like of shape (n,)
        Placement rule of the ``r > 0`` thresholds
        (:func:`core.fitting.thresholds.place_thresholds`) or explicit increasing positive
        thresholds (input units; then ``n_thresholds`` is their number).
    knots : {"uniform", "quantile"} or array_like of shape (m - 1,)
        Level knots: uniform over the training input range, at its quantiles
        (:func:`place_knots`), or explicit increasing knots (input units; then
        ``n_levels = len(knots) + 1``).
    r_max : float, optional
        Widest threshold (input units); default as :class:`~core.fitting.pi.PIRegressor`.
    include_offset : bool
        Fit a free output offset ``c`` (output units), stored in ``offset_``.
    validation : float
        Fraction at the end of every recording held out for the report when ``fit`` gets
        no ``train``/``test`` masks.
    min_slope : float, optional
        Lower bound ε of the reversible weights ``W[0, :]`` (output per input unit); default
        1e-3 × output range / input range. The inverse's slope is at most ``1/ε``.
    chunk : int
        Samples per streaming chunk.
    initial_memory : {"keep", "exclude"}
        As :class:`~core.fitting.pi.PIRegressor`: fit every training row from the relaxed
        state, or leave the rows before the wipe-out time out of the weight fit.
    constraint : {"nonnegative", "slopes"}
        Accepted for the common ``hyst fit --constraint`` option; both give the same fit.
        A Preisach density is non-negative, so ``W >= 0`` always; what ``"slopes"`` buys a PI
        model (branch slopes that fall, for saturating loops) the level segments already
        give, since ``W[i, j]`` may fall with the level ``j``. ``report_.extra`` records it.
    n_operators : int, optional
        Alias of ``n_thresholds`` (the keyword every fit kind takes: ``hyst fit -n``, the
        explorer); when given it overrides ``n_thresholds``.

    Attributes
    ----------
    model_ : PreisachModel
        Fitted model (without offset); ``state0`` relaxed at the first training
        recording's first input sample.
    offset_ : float
    full_model_ : Chain
        ``model_ >> Offset(offset_)``: serialisable and exactly invertible.
    thresholds_ : ndarray of shape (n + 1,)
        ``(0, r_1, ..., r_n)``.
    knots_ : ndarray of shape (m - 1,)
    weights_ : ndarray of shape (n + 1, m)
    n_thresholds_, n_levels_ : int
    min_slope_ : float
    report_ : FitReport

    Examples
    --------
    >>> import numpy as np
    >>> from core.pi import PIModel
    >>> t = np.linspace(0, 3, 3000)
    >>> u = 2 * np.sin(2 * np.pi * t)
    >>> y = PIModel(0.5, [0.4, 0.8, 1.2], [0.3, 0.2, 0.1])(u) + 1.0
    >>> est = PreisachRegressor(thresholds=[0.4, 0.8, 1.2], n_levels=1).fit(u, y)
    >>> round(est.offset_, 6), np.round(est.weights_[:, 0], 6).tolist()
    (1.0, [0.5, 0.3, 0.2, 0.1])
    """

    #: Both rules: the pre-wipe-out rows can be left out of the weight fit.
    initial_memory_rules: ClassVar[tuple[str, ...]] = INITIAL_MEMORY_RULES

    n_thresholds: int = 12
    n_levels: int = 4
    thresholds: str | ArrayLike = "uniform"
    knots: str | ArrayLike = "uniform"
    r_max: float | None = None
    include_offset: bool = True
    validation: float = 0.2
    min_slope: float | None = None
    chunk: int = DEFAULT_CHUNK
    initial_memory: str = "keep"
    constraint: str = "nonnegative"
    n_operators: int | None = None

    # ------------------------------------------------------------------ helpers
    def _sizes(self) -> tuple[int, int]:
        n = self.n_operators if self.n_operators is not None else self.n_thresholds
        if not isinstance(self.thresholds, str):
            n = as_vector(self.thresholds, "thresholds", positive=True, increasing=True).size
        m = self.n_levels
        if not isinstance(self.knots, str):
            m = as_vector(self.knots, "knots", min_length=0, increasing=True).size + 1
        return _positive_int(n, "n_thresholds"), _positive_int(m, "n_levels")

    def _grid(self, prep: Prepared, n: int, m: int) -> tuple[Float1D, Float1D]:
        if isinstance(self.thresholds, str):
            r = place_thresholds(prep.us, n, self.thresholds, self.r_max)
        else:
            r = as_vector(self.thresholds, "thresholds", positive=True, increasing=True)
        if isinstance(self.knots, str):
            e = place_knots(prep, m, self.knots)
        else:
            e = as_vector(self.knots, "knots", min_length=0, increasing=True)
        return np.concatenate(([0.0], r)), np.asarray(e, dtype=np.float64)

    # ------------------------------------------------------------------ API
    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Place thresholds and knots, fit the weights and the offset (the work of
        :meth:`fit`; it warns with :class:`FitWarning` when the design is nearly collinear
        or the loops run clockwise)."""
        if self.constraint not in ("nonnegative", "slopes"):
            raise ParameterError(
                f"constraint must be 'nonnegative' or 'slopes', got {self.constraint!r}"
            )
        n, m = self._sizes()
        p = 1 + (n + 1) * m
        prep_all = prepare(u, y, train, test, validation=self.validation,
                           min_train=max(20, 3 * (p + 1)))
        self.orientation_ = loop_orientation(prep_all.us, prep_all.ys, prep_all.train_masks)
        if self.orientation_.clockwise:
            warnings.warn(
                "the loops run clockwise (the output leads: friction-like or stress-strain "
                "data), and a Preisach model (non-negative density on play operators) has "
                "counter-clockwise loops only: fit the stop-pi or bouc-wen kind (or --model "
                "auto), which fit this orientation",
                FitWarning,
                stacklevel=3,
            )
        prep, memory_note = exclude_before_wipeout(prep_all, self.initial_memory)
        eps = self._min_slope(prep)
        r, e = self._grid(prep, n, m)
        segs = prep.segments(1)
        gram, spread = stream_level_gram(segs, r, e, n_labels=1, chunk=self.chunk)
        lower = np.concatenate(([-np.inf], np.full(m, eps), np.zeros(n * m)))
        # a column constant on the training rows is the offset in disguise: weight fixed
        scale = np.max(spread[1:]) if spread.size > 1 else 1.0
        fixed = np.zeros(p, dtype=bool)
        fixed[1:] = spread[1:] <= 1e-12 * max(scale, 1e-300)
        keep = ~fixed
        keep[0] = bool(self.include_offset)
        G = gram[0].copy()
        # move the fixed weights (their lower bound) to the right-hand side: y - Σ lb a
        T = np.eye(p + 1)
        T[:p, p][fixed] = -lower[fixed]
        G = T.T @ G @ T
        cols = np.r_[np.flatnonzero(keep), p]
        sol = solve_constrained(lower[keep], gram=G[np.ix_(cols, cols)])
        theta = np.where(fixed, lower, 0.0)
        theta[0] = 0.0
        theta[keep] = sol.theta
        if sol.cond > COND_LIMIT:
            warnings.warn(
                f"nearly collinear design (cond = {sol.cond:.2g}): fewer thresholds or level "
                "segments may suit this input travel",
                FitWarning,
                stacklevel=3,
            )
        W = theta[1:].reshape(n + 1, m)
        self.thresholds_ = r
        self.knots_ = e
        self.weights_ = W
        self.offset_ = float(theta[0])
        self.n_thresholds_ = n
        self.n_levels_ = m
        self.min_slope_ = eps
        self.model_ = PreisachModel(r, W, e, np.full(n + 1, float(prep.us[0][0])))
        self.full_model_ = Chain.of(self.model_, Offset(self.offset_))
        extra: dict[str, Any] = {
            "n_thresholds": n, "n_levels": m, "knots": e.tolist(), "min_slope": eps,
            "offset": self.offset_, "fixed_columns": int(fixed[1:].sum()),
            "initial_memory": memory_note, "constraint": "nonnegative",
            "orientation": self.orientation_.text + (
                "; a Preisach model has counter-clockwise loops only"
                if self.orientation_.clockwise else ""),
        }
        self.report_ = self._scored_report(
            prep_all.segments(1),
            model_type="preisach",
            n_parameters=int(keep.sum()),
            invertible=self.model_.is_invertible,
            min_slope=float(np.min(W[0])),
            condition_number=sol.cond,
            solver="gram-cholesky-nnls",
            extra=extra,
        )

    def _model_for(self, u: Float1D) -> PreisachModel:
        m = self.model_
        return PreisachModel(m.thresholds, m.weights, m.knots, np.full(m.n, float(u[0])))
