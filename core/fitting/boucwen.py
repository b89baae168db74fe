"""Identification of the rate-independent Bouc-Wen model: :class:`BoucWenRegressor`.

Model fitted (:class:`core.boucwen.BoucWenModel` plus an output offset)::

    y(t) ≈ c + κ u + Σ_j v_j (σ_j u - z_j(u)),   κ >= ε > 0,  v_j >= 0,  σ_j = max(1, s_j)

that is ``k = κ + Σ v_j σ_j`` and weights ``c_j = -v_j``. Each column ``σ_j u - z_j`` rises
with the input (``0 <= dz_j/du <= σ_j``), so the fitted model's smallest slope is ``κ >= ε``:
it is invertible by construction, with the counter-clockwise loop of a piezo actuator (the
orientation of the PI's plays). On clockwise data (the output leads: friction,
stress-strain; the signed loop area, :func:`core.fitting.orientation.loop_orientation`) the
columns are the elements ``z_j`` themselves, ``y ≈ c + κ u + Σ v_j z_j`` (``k = κ``,
``c_j = v_j``: the classical Bouc-Wen ``α k u + (1 - α) k z``), also rising with the input and
invertible; the report says which orientation was fitted.

Given the element shapes (saturation ``z_s``, reversal slope ``s``, exponent ``n``) the model
is linear in ``(c, κ, v)``: the weights come from bounded least squares
(:func:`core.fitting.gram.solve_constrained`) on a grid of shapes (saturations a fraction of
the training input range). The elements the grid keeps (at most ``n_operators``, the largest
contributions) then have their shapes polished by ``scipy.optimize.least_squares`` with the
weights solved inside (variable projection) on the same leading fraction of every recording
(at most :data:`POLISH_ROWS` training rows), and the weights are solved once more on all
training rows with the final model's own integration; elements left at weight 0 are
dropped. Every recording starts relaxed: ``z = 0`` at its first input sample, in ``fit`` and
in ``predict``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import Float1D, Float2D
from ..base import Chain
from ..boucwen import MAX_SUBSTEPS, BoucWenModel, bouc_wen_states
from ..exceptions import FitWarning, ParameterError, UnsupportedOptionError
from ..stages import Offset
from ._data import Prepared, masked_range, prepare
from .estimator import Estimator
from .gram import COND_LIMIT, nnls_checked, solve_constrained
from .orientation import loop_orientation

__all__ = ["BoucWenRegressor", "element_columns"]

#: Saturations of the shape grid, as fractions of the training input range.
GRID_SATURATIONS = (0.05, 0.1, 0.2, 0.35, 0.6, 1.0)
#: Reversal slopes ``s`` of the shape grid.
GRID_SLOPES = (1.0, 1.5, 2.5)
#: Exponents ``n`` of the shape grid.
GRID_EXPONENTS = (1.0, 2.0)
#: Elements kept when ``n_operators`` is None.
DEFAULT_ELEMENTS = 3
#: Most training rows the shape polish integrates and scores (the same leading fraction of
#: every recording beyond that).
POLISH_ROWS = 8_000


def element_columns(
    us: Sequence[Float1D], saturation: Float1D, slope: Float1D, exponent: Float1D,
    clockwise: bool = False,
) -> list[Float2D]:
    """The design columns ``σ_j u - z_j(u)`` of each recording, elements relaxed at ``u[0]``
    (``z_j(u)`` itself for ``clockwise`` loops).

    Each element is integrated with its own sub-step (``BoucWenModel.substep`` of that
    element alone, at most :data:`core.boucwen.MAX_SUBSTEPS` per sample).

    Parameters
    ----------
    us : sequence of ndarray of shape (N_i,)
        Inputs (input units).
    saturation, slope, exponent : ndarray of shape (m,)
        Element shapes ``z_s``, ``s``, ``n``.
    clockwise : bool
        Columns ``z_j`` (the output leads: friction, stress-strain) instead of the
        counter-clockwise ``σ_j u - z_j``; both rise with the input.

    Returns
    -------
    list of ndarray of shape (N_i, m)
    """
    sig = np.maximum(1.0, slope)
    out = []
    for u in us:
        cols = np.empty((u.size, saturation.size))
        for j in range(saturation.size):
            e = BoucWenModel(
                1.0, np.zeros(1), saturation[j : j + 1], slope[j : j + 1], exponent[j : j + 1]
            )
            Z, _ = bouc_wen_states(
                u,
                e.beta,
                e.gamma,
                e.exponent,
                None,
                max_step=e.substep,
                u0=float(u[0]),
                max_substeps=MAX_SUBSTEPS,
            )
            cols[:, j] = Z[:, 0] if clockwise else sig[j] * u - Z[:, 0]
        out.append(cols)
    return out


def _gram(
    us: Sequence[Float1D],
    ys: Sequence[Float1D],
    masks: Sequence[np.ndarray],
    cols: Sequence[Float2D],
) -> tuple[Float2D, Float1D]:
    """Augmented Gram matrix of ``[1, u, columns, y]`` on the masked rows, and the spread
    (max - min) of every parameter column there."""
    blocks = [
        np.column_stack((np.ones(int(m.sum())), u[m], c[m], y[m]))
        for u, y, m, c in zip(us, ys, masks, cols, strict=True)
    ]
    A = np.vstack(blocks)
    spread = np.ptp(A[:, :-1], axis=0) if A.shape[0] else np.zeros(A.shape[1] - 1)
    return A.T @ A, spread


def _solve(G: Float2D, spread: Float1D, eps: float, offset: bool) -> tuple[Float1D, float]:
    """Bounded least squares: offset free, κ >= ε, v >= 0; a column constant on the rows
    (an element that never leaves saturation) is fixed at 0. Returns θ and the condition."""
    p = G.shape[0] - 1
    lower = np.concatenate(([-np.inf, eps], np.zeros(p - 2)))
    keep = np.ones(p, dtype=bool)
    keep[0] = offset
    scale = float(np.max(spread[1:])) if p > 1 else 1.0
    keep[2:] &= spread[2:] > 1e-12 * max(scale, 1e-300)
    cols = np.r_[np.flatnonzero(keep), p]
    sol = solve_constrained(lower[keep], gram=G[np.ix_(cols, cols)])
    theta = np.zeros(p)
    theta[keep] = sol.theta
    return theta, float(sol.cond)


@dataclass(eq=False, repr=False)
class BoucWenRegressor(Estimator):
    """Fit an invertible rate-independent Bouc-Wen model (plus output offset).

    Parameters
    ----------
    n_operators : int, optional
        Most Bouc-Wen elements in the fitted model (default 3): the grid's largest
        contributions are kept and polished.
    saturations : sequence of float
        Saturations of the shape grid as fractions of the training input range.
    slopes, exponents : sequence of float
        Reversal slopes ``s`` and exponents ``n`` of the shape grid.
    polish : bool
        Polish the kept elements' shapes (``scipy.optimize.least_squares``).
    max_nfev : int
        Evaluation budget of the polish.
    include_offset : bool
        Fit a free output offset (output units), stored in ``offset_``.
    validation : float
        Fraction at the end of every recording held out for the report when ``fit`` gets
        no ``train``/``test`` masks.
    min_slope : float, optional
        Lower bound ε of the smallest slope ``κ`` (output per input unit); default 1e-3 ×
        output range / input range.
    constraint : {"nonnegative"}
        Taken by every estimator; the invertibility rule here is ``κ >= ε`` and ``v >= 0``
        (``"slopes"`` raises :class:`~core.exceptions.UnsupportedOptionError`).
    initial_memory : {"keep"}
        Every recording starts relaxed; ``"exclude"`` raises
        :class:`~core.exceptions.UnsupportedOptionError`.

    Attributes
    ----------
    model_ : BoucWenModel
        Fitted model (without offset), relaxed at the first recording's first input.
    offset_ : float
    full_model_ : Chain
        ``model_ >> Offset(offset_)``; inverse via ``full_model_.inverse()``.
    grid_error_ : float
        Training RMSE of the grid fit (output units), before the polish.
    report_ : FitReport
    """

    # (initial_memory_rules: the base's "keep" only; no wipe-out rule for a fading memory)

    n_operators: int | None = None
    saturations: Sequence[float] = GRID_SATURATIONS
    slopes: Sequence[float] = GRID_SLOPES
    exponents: Sequence[float] = GRID_EXPONENTS
    polish: bool = True
    max_nfev: int = 15
    include_offset: bool = True
    validation: float = 0.2
    min_slope: float | None = None
    constraint: str = "nonnegative"
    initial_memory: str = "keep"

    # ------------------------------------------------------------------ helpers
    def _n_elements(self) -> int:
        n = DEFAULT_ELEMENTS if self.n_operators is None else self.n_operators
        if isinstance(n, bool) or int(n) != n or not 1 <= n <= 50:
            raise ParameterError(
                f"n_operators = {n!r}: the number of Bouc-Wen elements must be a whole "
                "number from 1 to 50"
            )
        return int(n)

    def _grid(self, span: float) -> tuple[Float1D, Float1D, Float1D]:
        f = as_positive(self.saturations, "saturations")
        s = np.asarray(self.slopes, dtype=np.float64).ravel()
        n = np.asarray(self.exponents, dtype=np.float64).ravel()
        if s.size == 0 or not np.all((s >= 0) & (s <= 10)):
            raise ParameterError(f"slopes = {self.slopes!r}: reversal slopes lie in 0..10")
        if n.size == 0 or not np.all((n >= 1) & (n <= 10)):
            raise ParameterError(f"exponents = {self.exponents!r}: exponents lie in 1..10")
        F, S, N = np.meshgrid(f * span, s, n, indexing="ij")
        return F.ravel(), S.ravel(), N.ravel()

    def _fit_shapes(
        self, prep: Prepared, zs: Float1D, s: Float1D, n: Float1D, eps: float
    ) -> tuple[Float1D, float]:
        cols = element_columns(prep.us, zs, s, n, self.orientation_.clockwise)
        G, spread = _gram(prep.us, prep.ys, prep.train_masks, cols)
        return _solve(G, spread, eps, bool(self.include_offset))

    def _polish(
        self, prep: Prepared, zs: Float1D, s: Float1D, n: Float1D, eps: float
    ) -> tuple[Float1D, Float1D, Float1D]:
        """Shapes by ``least_squares`` (log z_s, s, n), weights solved inside."""
        import scipy.optimize

        # the same leading fraction of every recording, at most POLISH_ROWS training rows
        # in all: only those samples are integrated at each evaluation
        frac = min(1.0, POLISH_ROWS / max(prep.n_train, 1))
        heads = [max(2, int(np.ceil(frac * u.size))) for u in prep.us]
        us = [u[:h] for u, h in zip(prep.us, heads, strict=True)]
        rows = [m[:h] for m, h in zip(prep.train_masks, heads, strict=True)]
        y = np.concatenate([y[:h][r] for y, h, r in zip(prep.ys, heads, rows, strict=True)])
        k = zs.size

        def unpack(x: Float1D) -> tuple[Float1D, Float1D, Float1D]:
            return np.exp(x[:k]), x[k : 2 * k], x[2 * k :]

        offset = bool(self.include_offset)
        us_r = np.concatenate([u[r] for u, r in zip(us, rows, strict=True)])

        def resid(x: Float1D) -> Float1D:
            a, b, c = unpack(x)
            cols = element_columns(us, a, b, c, self.orientation_.clockwise)
            A = np.column_stack(
                (us_r, np.vstack([cc[r] for cc, r in zip(cols, rows, strict=True)]))
            )
            return _nnls_residual(A, y - eps * us_r, offset)

        x0 = np.concatenate((np.log(zs), s, n))
        lo = np.concatenate((np.log(zs) - 3.0, np.zeros(k), np.ones(k)))
        hi = np.concatenate((np.log(zs) + 3.0, np.full(k, 10.0), np.full(k, 10.0)))
        x0 = np.clip(x0, lo, hi)
        res = scipy.optimize.least_squares(
            resid, x0, bounds=(lo, hi), x_scale="jac", max_nfev=int(self.max_nfev), diff_step=1e-4
        )
        return unpack(res.x)

    # ------------------------------------------------------------------ API
    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Fit the element shapes, the weights and the offset (the work of :meth:`fit`)."""
        self._check_initial_memory()
        if self.constraint != "nonnegative":
            raise UnsupportedOptionError(
                f"a Bouc-Wen fit cannot use constraint={self.constraint!r}: its weights are "
                "kept invertible by a smallest slope >= min_slope; use 'nonnegative'"
            )
        m_max = self._n_elements()
        prep = prepare(u, y, train, test, validation=self.validation, min_train=40)
        eps = self._min_slope(prep)
        span = masked_range(prep.us, prep.train_masks) or masked_range(prep.us)
        self.orientation_ = loop_orientation(prep.us, prep.ys, prep.train_masks)
        cw = self.orientation_.clockwise
        zs, s, n = self._grid(span)
        theta, _ = self._fit_shapes(prep, zs, s, n, eps)
        cols = element_columns(prep.us, zs, s, n, cw)
        contrib = theta[2:] * np.array(
            [
                np.std(
                    np.concatenate([c[m, j] for c, m in zip(cols, prep.train_masks, strict=True)])
                )
                for j in range(zs.size)
            ]
        )
        order = np.argsort(-contrib)
        active = order[:m_max][contrib[order[:m_max]] > 0]
        if active.size == 0:  # no hysteresis found: keep the widest loop at weight ~0
            active = order[:1]
        zs, s, n = zs[active], s[active], n[active]
        self.grid_error_ = self._train_rmse(prep, zs, s, n, eps)
        if self.polish:
            zs, s, n = self._polish(prep, zs, s, n, eps)
        model = BoucWenModel(1.0, np.zeros(zs.size), zs, s, n)
        # the final weights with the model's own integration (one sub-step for all)
        cols = [self._columns(model, x, cw) for x in prep.us]
        G, spread = _gram(prep.us, prep.ys, prep.train_masks, cols)
        theta, cond = _solve(G, spread, eps, bool(self.include_offset))
        if cond > COND_LIMIT:
            warnings.warn(
                f"nearly collinear Bouc-Wen elements (cond = {cond:.2g}): fewer "
                "elements (n_operators) may suit this input travel",
                FitWarning,
                stacklevel=3,
            )
        sig = np.maximum(1.0, s)
        v = theta[2:]
        used = v > 0
        if used.any() and not used.all():  # elements the final solve left at zero
            zs, s, n, sig, v = zs[used], s[used], n[used], sig[used], v[used]
        # counter-clockwise: y = κ u + Σ v (σ u - z); clockwise: y = κ u + Σ v z
        k = float(theta[1]) if cw else float(theta[1] + np.sum(v * sig))
        self.offset_ = float(theta[0])
        self.model_ = BoucWenModel(k, v if cw else -v, zs, s, n, input0=float(prep.us[0][0]))
        self.full_model_ = Chain.of(self.model_, Offset(self.offset_))
        self.report_ = self._scored_report(
            prep.segments(1),
            model_type="bouc-wen",
            n_parameters=int(1 + self.include_offset + 4 * zs.size),
            invertible=self.model_.is_invertible,
            min_slope=self.model_.slope_bounds()[0],
            condition_number=cond,
            solver="grid-nnls" + ("+least-squares-polish" if self.polish else ""),
            extra={
                "n_elements": int(zs.size),
                "grid_train_rmse": self.grid_error_,
                "min_slope_bound": eps,
                "offset": self.offset_,
                "saturation": zs.tolist(),
                "reversal_slope": s.tolist(),
                "exponent": n.tolist(),
                "orientation": self.orientation_.text + (
                    "; fitted with the elements themselves, y = k u + sum c_j z_j, c_j >= 0"
                    if cw else "; fitted with y = k u - sum v_j z_j, v_j >= 0"),
            },
        )

    def _train_rmse(self, prep: Prepared, zs: Float1D, s: Float1D, n: Float1D, eps: float) -> float:
        cols = element_columns(prep.us, zs, s, n, self.orientation_.clockwise)
        G, spread = _gram(prep.us, prep.ys, prep.train_masks, cols)
        theta, _ = _solve(G, spread, eps, bool(self.include_offset))
        sse = theta @ G[:-1, :-1] @ theta - 2 * theta @ G[:-1, -1] + G[-1, -1]
        return float(np.sqrt(max(sse, 0.0) / max(prep.n_train, 1)))

    @staticmethod
    def _columns(model: BoucWenModel, u: Float1D, clockwise: bool = False) -> Float2D:
        Z = model.states(u, state=(float(u[0]), np.zeros(model.n)))
        return Z if clockwise else np.maximum(1.0, model.reversal_slope) * u[:, None] - Z

    def _model_for(self, u: Float1D) -> BoucWenModel:
        m = self.model_
        return BoucWenModel(
            m.k, m.weights, m.saturation, m.reversal_slope, m.exponent, input0=float(u[0])
        )


def _nnls_residual(A: Float2D, y: Float1D, offset: bool) -> Float1D:
    """Residual of ``min ||A θ (+ c) - y||`` with ``θ >= 0`` (a free offset ``c`` removed by
    centring the columns and ``y``), solved by :func:`core.fitting.gram.nnls_checked`
    (scipy's ``nnls`` with its optimality conditions checked: scipy >= 1.16 can stop at a
    point that is not the minimum, which would make this residual jump between polish steps)."""
    if offset:
        A = A - A.mean(axis=0)
        y = y - y.mean()
    scale = np.sqrt(np.sum(A * A, axis=0))
    scale[scale == 0] = 1.0
    As = A / scale
    theta, _ = nnls_checked(As, y, 3 * As.shape[1])
    return As @ theta - y


def as_positive(x: Any, name: str) -> Float1D:
    """A non-empty vector of positive finite numbers (``ParameterError`` naming ``name``)."""
    a = np.asarray(x, dtype=np.float64).ravel()
    if a.size == 0 or not np.all(np.isfinite(a) & (a > 0)):
        raise ParameterError(f"{name} = {x!r} must be positive numbers")
    return a
