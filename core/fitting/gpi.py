"""Identification of generalized PI models, every result invertible by construction.

* :class:`DeadZoneGPIRegressor` — paper 001 order, ``y = c + P[γ(v)]``: the dead-zone
  superposition γ on the input. Separable fit: γ's partial slopes (bounded below by
  ``deadzone_min_slope``, so γ stays strictly increasing) are optimised by
  ``scipy.optimize.least_squares``; for every trial γ the PI weights and offset are the
  exact constrained least-squares solution (variable projection).
* :class:`ModifiedPIRegressor` — Kuhnen's order, ``y = c0 + S[P[v] + c1]``: the dead-zone
  superposition on the PI output. Kuhnen's linear-in-parameters identification: the
  *inverse* output map ``S⁻¹`` is also a dead-zone superposition, so
  ``P[v] + c1 = S⁻¹[y - c0]`` is linear in the PI weights and in ``S⁻¹``'s partial slopes;
  one NNLS solve on the streamed normal equations gives both (the slope of ``S⁻¹`` next to
  0 is fixed to 1 to remove the scale ambiguity; every other partial slope ``>= ε``). The
  loss is the "generalized error" in the PI output domain; the report gives the honest
  output-domain errors.
* :class:`TanhGPIRegressor` — ``y = c + P[κ[v]]`` with the tanh envelope κ (paper 001
  eq. 44-47): the envelope parameters by ``least_squares``, the PI weights by NNLS inside
  (variable projection). ``asymmetric=False`` (default) uses one branch ``κ_R = κ_L``
  (memoryless, exactly invertible); ``asymmetric=True`` fits a second branch.

The nonlinear fits keep the transformed input and the training residual in memory (O(N)
floats); the classical :class:`~core.fitting.pi.PIRegressor` and the linear MPI fit stream.
Scale conventions remove the exact ambiguities of the cascades: γ has slope 1 around 0
(``η_0 = 1``), κ has ``a0 = 1, a3 = 0`` (its output is in (-1, 1)), ``S⁻¹`` has ``μ_0 = 1``.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import Float1D
from ..base import Chain, Model
from ..deadzone import DeadZoneMap
from ..exceptions import ClippedInputWarning, FitWarning, ParameterError
from ..gpi import DeadZoneGPI, ModifiedPI, TanhEnvelope, TanhGPI
from ..operators import dead_zone
from ..pi import PIModel
from ..stages import Offset
from ..validation import filled
from ..warning_filters import FILTERS
from ._data import Prepared, masked_range, prepare
from .estimator import Estimator
from .gram import DEFAULT_CHUNK, Segment
from .metrics import FitReport
from .pi import LinearPIFit, PIRegressor, fit_linear_pi
from .thresholds import reversal_indices, thresholds_from_travels, travels_at

__all__ = ["DeadZoneGPIRegressor", "ModifiedPIRegressor", "TanhGPIRegressor"]


def _relaxed(p0: float, r: Float1D, w: Float1D, x0: float) -> PIModel:
    return PIModel(p0, r, w, np.full(r.size, float(x0)))


def _classical_extra(classical: PIRegressor) -> dict[str, Any]:
    """The classical start's errors, reported beside the fit that must beat them."""
    test = classical.report_.test
    return {"classical_test_rmse": None if test is None else test.rmse,
            "classical_train_rmse": classical.report_.train.rmse}


class _Base(Estimator):
    """Shared plumbing: classical start, PI solve on a transformed input. These fits start
    every recording relaxed (the base's ``initial_memory="keep"`` only), and their
    ``_model_for`` includes the output offset."""

    n_operators: int | None
    thresholds: str
    include_offset: bool
    validation: float
    min_slope: float | None
    constraint: str
    chunk: int

    # -------------------------------------------------------------- common steps
    def _prepare(self, u: Any, y: Any, train: Any, test: Any) -> Prepared:
        self._check_initial_memory()
        n_min = self.n_operators or 5
        return prepare(
            u, y, train, test, validation=self.validation, min_train=max(30, 4 * (n_min + 8))
        )

    def _masks(self, prep: Prepared) -> tuple[Any, Any]:
        if prep.multi:
            return prep.train_masks, prep.test_masks
        return prep.train_masks[0], prep.test_masks[0]

    def _classical(self, prep: Prepared) -> PIRegressor:
        tr, te = self._masks(prep)
        with FILTERS, warnings.catch_warnings():
            warnings.simplefilter("ignore", FitWarning)
            return PIRegressor.classical_start(self).fit(
                prep.us if prep.multi else prep.us[0], prep.ys if prep.multi else prep.ys[0],
                train=tr, test=te)

    def _reversals(self, prep: Prepared) -> list[np.ndarray]:
        tol = 1e-3 * masked_range(prep.us)
        return [reversal_indices(u, tol) for u in prep.us]

    def _solve_pi(
        self, prep: Prepared, ws: Sequence[Float1D], rev: Sequence[np.ndarray], n: int
    ) -> tuple[LinearPIFit, Float1D, float]:
        """Thresholds (rule on ``w``) and constrained weights of ``y ≈ c + P[w]``."""
        r = thresholds_from_travels(travels_at(ws, rev), n, self.thresholds)
        segs = [
            Segment(u=w, y=s.y, labels=s.labels) for w, s in zip(ws, prep.segments(1), strict=True)
        ]
        if self.min_slope is not None:
            eps = float(self.min_slope)
        else:
            eps = 1e-3 * masked_range(prep.ys, prep.train_masks) / max(
                masked_range(ws, prep.train_masks), 1e-300
            )
        fit = fit_linear_pi(
            segs, r, min_slope=eps, include_offset=self.include_offset, chunk=self.chunk,
            constraint=self.constraint, allow_tsqr=False,
        )
        return fit, r, eps

    def _keep(self, classical: PIRegressor, n: int, fit: LinearPIFit, r: Float1D,
              model: Model) -> None:
        """The fitted attributes of a fit with a classical start (the input map's own is set
        by the caller): ``model_`` and ``full_model_ = model_ >> Offset(offset_)``."""
        self.offset_ = fit.offset
        self.n_operators_ = n
        self.classical_ = classical
        self._pi = (fit.p0, r, fit.weights)
        self.model_ = model
        self.full_model_: Model = Chain.of(model, Offset(fit.offset))

    def _train_residual(
        self, prep: Prepared, ws: Sequence[Float1D], fit: LinearPIFit, r: Float1D
    ) -> Float1D:
        out = []
        for w, y, m in zip(ws, prep.ys, prep.train_masks, strict=True):
            yh = _relaxed(fit.p0, r, fit.weights, w[0])(w) + fit.offset
            out.append((yh - y)[m])
        return np.concatenate(out)

    def _report(
        self,
        prep: Prepared,
        model_for: Any,
        n_par: int,
        model_type: str,
        cond: float,
        solver: str,
        min_slope: float,
        extra: dict[str, Any],
        invertible: bool = True,
    ) -> FitReport:
        """The base's scored report (offset inside ``model_for``), with the chunks whose
        inverse input was clipped counted in ``extra`` instead of warned one by one."""
        with FILTERS, warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ClippedInputWarning)
            report = self._scored_report(
                prep.segments(1), model_for=model_for, offset=0.0, run_inverse=invertible,
                model_type=model_type, n_parameters=n_par, invertible=invertible,
                min_slope=min_slope, condition_number=cond, solver=solver, extra=extra,
            )
        clipped = [w for w in caught if issubclass(w.category, ClippedInputWarning)]
        for w in caught:
            if not issubclass(w.category, ClippedInputWarning):
                warnings.warn(w.message, w.category, stacklevel=3)
        if clipped:
            extra["inverse_clipped_chunks"] = len(clipped)
        return report

    # -------------------------------------------------------------- API
    def _output(self, u: Float1D) -> Float1D:
        """Predicted output of one record: ``_model_for`` holds the offset already."""
        out: Float1D = self._model_for(u)(u)
        return out


def _uniform_knots(lo: float, hi: float, m: int) -> tuple[Float1D, Float1D]:
    """``m`` negative knots in (lo, 0) and ``m`` positive knots in (0, hi), evenly spaced."""
    pos = hi * np.arange(1, m + 1) / (m + 1) if hi > 0 else np.zeros(0)
    neg = lo * np.arange(m, 0, -1) / (m + 1) if lo < 0 else np.zeros(0)
    return neg, pos


def _deadzone_from_slopes(neg: Float1D, pos: Float1D, s_neg: Float1D, s_pos: Float1D,
                          s0: float = 1.0) -> DeadZoneMap:
    """DeadZoneMap with slope ``s0`` around 0 and the given outer partial slopes.

    ``s_pos[j]`` is the slope right of ``pos[j]``; ``s_neg[j]`` the slope left of ``neg[j]``
    (``neg`` increasing, so ``s_neg[0]`` is the outermost)."""
    eta_pos = np.diff(np.concatenate(([s0], s_pos)))
    # negative side, from 0 outwards: knots neg[::-1], slopes s_neg[::-1]
    eta_neg_out = np.diff(np.concatenate(([s0], s_neg[::-1])))
    return DeadZoneMap(
        np.concatenate((neg, [0.0], pos)), np.concatenate((eta_neg_out[::-1], [s0], eta_pos))
    )


@dataclass(eq=False, repr=False)
class _DeadZoneFit(_Base):
    """The options and checks of the two dead-zone fits (γ on the input, S on the output):
    the parameters are documented on :class:`DeadZoneGPIRegressor` and
    :class:`ModifiedPIRegressor`, which add their own after these."""

    n_operators: int | None = None
    n_deadzones: int = 3
    thresholds: str = "uniform"
    include_offset: bool = True
    validation: float = 0.2
    min_slope: float | None = None
    deadzone_min_slope: float = 0.05
    constraint: str = "nonnegative"
    chunk: int = DEFAULT_CHUNK
    initial_memory: str = "keep"

    def _check_deadzones(self) -> None:
        if int(self.n_deadzones) != self.n_deadzones or self.n_deadzones < 1:
            raise ParameterError(f"n_deadzones must be a positive integer, got {self.n_deadzones}")
        if not 0 < self.deadzone_min_slope < 1:
            raise ParameterError("deadzone_min_slope must be in (0, 1) (relative to slope 1)")


# =====================================================================================
@dataclass(eq=False, repr=False)
class DeadZoneGPIRegressor(_DeadZoneFit):
    """Fit ``y = c + P[γ(v)]`` (paper 001 dead-zone GPI) with invertible γ and P.

    Parameters
    ----------
    n_operators : int, optional
        Play operators of P; ``None``: chosen by the classical fit's cross-validation.
    n_deadzones : int
        Dead-zone knots per side of γ (evenly spaced between 0 and the input extremes).
    thresholds : {"uniform", "quantile"}
        Placement rule of P's thresholds on the transformed input ``w = γ(v)``.
    include_offset : bool
        Fit the output offset ``c``.
    validation : float
        Held-out fraction at the end of each record when ``fit`` has no masks.
    min_slope : float, optional
        Lower bound of P's slopes (see :class:`~core.fitting.pi.PIRegressor`).
    deadzone_min_slope : float
        Lower bound of γ's partial slopes relative to the slope 1 around 0.
    constraint : {"nonnegative", "slopes"}
        Invertibility constraint of P.
    chunk : int
        Samples per streaming chunk.
    initial_memory : {"keep"}
        Taken by every estimator (one signature, :func:`core.fitting.fit_recordings`);
        this fit starts every recording relaxed, so ``"exclude"`` raises
        :class:`~core.exceptions.UnsupportedOptionError`.
    max_nfev : int
        Evaluation budget of ``least_squares``.

    Attributes
    ----------
    model_ : DeadZoneGPI
    offset_ : float
    full_model_ : Chain
        ``model_ >> Offset(offset_)``; exact inverse via ``full_model_.inverse()``.
    deadzone_ : DeadZoneMap
    classical_ : PIRegressor
        The classical start (its report is the baseline the GPI must beat).
    report_ : FitReport
    """

    max_nfev: int = 100

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Fit γ, P and the offset (the work of :meth:`fit`)."""
        import scipy.optimize

        self._check_deadzones()
        prep = self._prepare(u, y, train, test)
        classical = self._classical(prep)
        n = classical.n_operators_
        lo = min(float(x.min()) for x in prep.us)
        hi = max(float(x.max()) for x in prep.us)
        neg, pos = _uniform_knots(lo, hi, int(self.n_deadzones))
        rev = self._reversals(prep)
        k_neg = neg.size

        def gamma(s: Float1D) -> DeadZoneMap:
            return _deadzone_from_slopes(neg, pos, s[:k_neg], s[k_neg:])

        def residual(s: Float1D) -> Float1D:
            g = gamma(s)
            ws = [g(x) for x in prep.us]
            fit, r, _ = self._solve_pi(prep, ws, rev, n)
            return self._train_residual(prep, ws, fit, r)

        s0 = np.ones(neg.size + pos.size)
        res = scipy.optimize.least_squares(
            residual,
            s0,
            bounds=(np.full(s0.size, self.deadzone_min_slope), np.full(s0.size, np.inf)),
            method="trf",
            x_scale=1.0,
            diff_step=1e-4,
            max_nfev=self.max_nfev,
        )
        g = gamma(res.x)
        ws = [g(x) for x in prep.us]
        fit, r, eps = self._solve_pi(prep, ws, rev, n)
        self.deadzone_ = g
        gpi = DeadZoneGPI(_relaxed(fit.p0, r, fit.weights, ws[0][0]), g)
        self._keep(classical, n, fit, r, gpi)
        slopes = np.cumsum(np.r_[fit.p0, fit.weights])
        if not res.success:
            warnings.warn(f"dead-zone GPI fit did not converge: {res.message}", FitWarning,
                          stacklevel=2)
        extra = {
            "n_operators": n,
            "deadzone_thresholds": g.thresholds,
            "deadzone_slopes": g.slopes,
            "nfev": int(res.nfev),
            **_classical_extra(classical),
        }
        self.report_ = self._report(
            prep, self._model_for, n + 1 + int(self.include_offset) + s0.size, "gpi-deadzone",
            fit.cond, "least_squares(γ slopes) + gram-cholesky-nnls(P)",
            float(min(slopes.min(), g.slopes.min())), extra,
            invertible=gpi.pi.is_invertible and g.is_invertible,
        )

    def _model_for(self, u: Float1D) -> Model:
        p0, r, w = self._pi
        x0 = float(self.deadzone_(np.asarray(u[:1]))[0])
        return Chain.of(DeadZoneGPI(_relaxed(p0, r, w, x0), self.deadzone_), Offset(self.offset_))


# =====================================================================================
class ModifiedPIRegressor(_DeadZoneFit):
    """Fit Kuhnen's modified PI ``y = c0 + S[P[v] + c1]`` (dead zones on the PI output).

    Parameters
    ----------
    n_operators : int, optional
        Play operators of P; ``None``: chosen by the classical fit's cross-validation.
    n_deadzones : int
        Knots per side of the inverse output map ``S⁻¹`` (evenly spaced between the centre
        ``c0`` of the training output range and its extremes).
    thresholds : {"uniform", "quantile"}
        Threshold rule of P (on the input).
    include_offset : bool
        Fit the inner offset ``c1`` (the outer ``c0`` is the midrange of the training output).
    validation : float
        Held-out fraction when ``fit`` has no masks.
    min_slope : float, optional
        Lower bound of P's slopes.
    deadzone_min_slope : float
        Lower bound of ``S⁻¹``'s partial slopes relative to its slope 1 around 0 (``S`` then
        has partial slopes ``<= 1/deadzone_min_slope``).
    constraint : {"nonnegative", "slopes"}
        Invertibility constraint of P.
    chunk : int
        Samples per streaming chunk.
    initial_memory : {"keep"}
        Taken by every estimator (one signature, :func:`core.fitting.fit_recordings`);
        this fit starts every recording relaxed, so ``"exclude"`` raises
        :class:`~core.exceptions.UnsupportedOptionError`.

    Attributes
    ----------
    model_ : ModifiedPI
        ``S[P[·]]`` without the offsets.
    offset_ : float
        Outer output offset ``c0``.
    inner_offset_ : float
        ``c1``, added to P's output before S.
    full_model_ : Chain
        ``P >> Offset(c1) >> S >> Offset(c0)``; reproduces ``predict``, exact inverse.
    deadzone_ : DeadZoneMap
        ``S``.
    report_ : FitReport
    """

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Fit P, S and the offsets (the work of :meth:`fit`)."""
        self._check_deadzones()
        prep = self._prepare(u, y, train, test)
        if self.n_operators is None:
            n = self._classical(prep).n_operators_
        else:
            n = int(self.n_operators)
        lo_t = min(float(y[m].min()) for y, m in zip(prep.ys, prep.train_masks, strict=True)
                   if m.any())
        hi_t = max(float(y[m].max()) for y, m in zip(prep.ys, prep.train_masks, strict=True)
                   if m.any())
        c0 = 0.5 * (lo_t + hi_t)
        neg, pos = _uniform_knots(lo_t - c0, hi_t - c0, int(self.n_deadzones))
        knots = np.concatenate((neg, pos))

        def ramps(yc: Float1D) -> Float1D:
            """Columns -B_j(y'): B_j = S_τj - S_τ(j+1) outward (zero beyond the last)."""
            cols = np.empty((yc.size, knots.size))
            # positive side, j = 0..m-1: S_pos[j] - S_pos[j+1]
            sp = [dead_zone(yc, t) for t in pos] + [np.zeros(yc.size)]
            for j in range(pos.size):
                cols[:, neg.size + j] = -(sp[j] - sp[j + 1])
            # negative side, outward order neg[::-1]; column order follows ``neg``
            sn_out = [dead_zone(yc, t) for t in neg[::-1]] + [np.zeros(yc.size)]
            for j in range(neg.size):
                cols[:, neg.size - 1 - j] = -(sn_out[j] - sn_out[j + 1])
            return cols

        segs = []
        for s, y in zip(prep.segments(1), prep.ys, strict=True):
            yp = y - c0
            target = yp.copy()
            if pos.size:
                target -= dead_zone(yp, float(pos[0]))
            if neg.size:
                target -= dead_zone(yp, float(neg[-1]))
            segs.append(Segment(u=s.u, y=target, labels=s.labels, aux=yp))
        r = thresholds_from_travels(travels_at(prep.us, self._reversals(prep)), n, self.thresholds)
        eps = (
            float(self.min_slope)
            if self.min_slope is not None
            else 1e-3 * (hi_t - lo_t) / max(masked_range(prep.us, prep.train_masks), 1e-300)
        )
        fit = fit_linear_pi(
            segs, r, min_slope=eps, include_offset=self.include_offset,
            extra=lambda uc, yc, ac: ramps(filled(ac)), extra_lower=np.full(knots.size,
                                                                    self.deadzone_min_slope),
            chunk=self.chunk, constraint=self.constraint,
        )
        s_all = fit.extra
        s_inv = _deadzone_from_slopes(neg, pos, s_all[: neg.size], s_all[neg.size :])
        S = s_inv.inverse()
        self.deadzone_ = S
        self.inverse_deadzone_ = s_inv
        self.offset_ = c0
        self.inner_offset_ = fit.offset
        self.n_operators_ = n
        self._pi = (fit.p0, r, fit.weights)
        self.model_ = ModifiedPI(_relaxed(fit.p0, r, fit.weights, prep.us[0][0]), S)
        self.full_model_ = self._model_for(prep.us[0])
        slopes = np.cumsum(np.r_[fit.p0, fit.weights])
        extra = {
            "n_operators": n,
            "generalized_error_rmse": float(np.sqrt(fit.sse / prep.n_train)),
            "output_deadzone_thresholds": S.thresholds,
            "output_deadzone_slopes": S.slopes,
            "inner_offset": fit.offset,
            "outer_offset": c0,
        }
        self.report_ = self._report(
            prep, self._model_for, n + 1 + int(self.include_offset) + knots.size, "mpi",
            fit.cond, fit.solver + " (Kuhnen generalized error)",
            float(min(slopes.min(), S.slopes.min())), extra,
            invertible=self.model_.pi.is_invertible and S.is_invertible,
        )

    def _model_for(self, u: Float1D) -> Model:
        p0, r, w = self._pi
        return Chain.of(
            _relaxed(p0, r, w, u[0]), Offset(self.inner_offset_), self.deadzone_,
            Offset(self.offset_),
        )


# =====================================================================================
@dataclass(eq=False, repr=False)
class TanhGPIRegressor(_Base):
    """Fit ``y = c + P[κ(v)]`` with the tanh envelope κ (paper 001 eq. 44-47).

    Envelope convention: ``κ_R(v) = tanh(a1 v + a2)`` (``a0 = 1``, ``a3 = 0``: P's weights
    and the offset absorb scale and shift); with ``asymmetric=True`` the falling branch
    ``κ_L(v) = tanh(b1 v + b2) + b3`` is fitted too. Positivity of ``a1``, ``b1`` (an
    increasing envelope) is enforced by optimising their logarithms.

    Parameters
    ----------
    n_operators : int, optional
        Play operators of P; ``None``: chosen by the classical fit's cross-validation.
    asymmetric : bool
        Fit separate rising / falling branches (then the inverse is exact only one way;
        see :mod:`core.gpi`).
    thresholds, include_offset, validation, min_slope, constraint, max_nfev, chunk, initial_memory
        As in :class:`DeadZoneGPIRegressor`.

    Attributes
    ----------
    model_ : TanhGPI
    envelope_ : TanhEnvelope
    offset_ : float
    full_model_ : Chain
    report_ : FitReport
    """

    n_operators: int | None = None
    asymmetric: bool = False
    thresholds: str = "uniform"
    include_offset: bool = True
    validation: float = 0.2
    min_slope: float | None = None
    constraint: str = "nonnegative"
    max_nfev: int = 60
    chunk: int = DEFAULT_CHUNK
    initial_memory: str = "keep"

    def _envelope(self, phi: Float1D) -> TanhEnvelope:
        a = np.array([1.0, np.exp(phi[0]) / self._vs, phi[1] - np.exp(phi[0]) * self._vc / self._vs,
                      0.0])
        if not self.asymmetric:
            return TanhEnvelope(a, a.copy())
        b = np.array([1.0, np.exp(phi[2]) / self._vs,
                      phi[3] - np.exp(phi[2]) * self._vc / self._vs, phi[4]])
        return TanhEnvelope(a, b)

    def _fit(self, u: Any, y: Any, train: Any, test: Any) -> None:
        """Fit κ, P and the offset (the work of :meth:`fit`)."""
        import scipy.optimize

        prep = self._prepare(u, y, train, test)
        classical = self._classical(prep)
        n = classical.n_operators_
        lo = min(float(x.min()) for x in prep.us)
        hi = max(float(x.max()) for x in prep.us)
        # normalised input: a1 v + a2 = e^phi0 (v - vc)/vs + phi1
        self._vc, self._vs = 0.5 * (lo + hi), 0.5 * (hi - lo)
        rev = self._reversals(prep)

        def transformed(phi: Float1D) -> list[Float1D]:
            env = self._envelope(phi)
            if not self.asymmetric:  # memoryless: skip the direction bookkeeping
                a = env.a
                return [np.tanh(a[1] * x + a[2]) for x in prep.us]
            return [env(x) for x in prep.us]

        def residual(phi: Float1D) -> Float1D:
            ws = transformed(phi)
            fit, r, _ = self._solve_pi(prep, ws, rev, n)
            return self._train_residual(prep, ws, fit, r)

        # start nearly linear: tanh on about +-0.5 around the input centre
        x0 = np.array([np.log(0.5), 0.0])
        lo_b = np.array([np.log(1e-3), -3.0])
        hi_b = np.array([np.log(10.0), 3.0])
        if self.asymmetric:
            x0 = np.r_[x0, x0, 0.0]
            lo_b = np.r_[lo_b, lo_b, -1.0]
            hi_b = np.r_[hi_b, hi_b, 1.0]
        best = scipy.optimize.least_squares(
            residual, x0, method="trf", diff_step=1e-4, max_nfev=self.max_nfev,
            bounds=(lo_b, hi_b), ftol=1e-6, xtol=1e-6,
        )
        if not best.success:
            warnings.warn(f"tanh GPI fit stopped early: {best.message}", FitWarning, stacklevel=2)
        env = self._envelope(best.x)
        ws = transformed(best.x)
        fit, r, eps = self._solve_pi(prep, ws, rev, n)
        self.envelope_ = env
        tgpi = TanhGPI(_relaxed(fit.p0, r, fit.weights, ws[0][0]), env)
        self._keep(classical, n, fit, r, tgpi)
        slopes = np.cumsum(np.r_[fit.p0, fit.weights])
        extra = {
            "n_operators": n,
            "envelope_a": env.a,
            "envelope_b": env.b,
            "nfev": int(best.nfev),
            **_classical_extra(classical),
        }
        self.report_ = self._report(
            prep, self._model_for, n + 1 + int(self.include_offset) + best.x.size, "gpi-tanh",
            fit.cond, "least_squares(envelope) + gram-cholesky-nnls(P)", float(slopes.min()),
            extra, invertible=tgpi.pi.is_invertible,
        )

    def _model_for(self, u: Float1D) -> Model:
        p0, r, w = self._pi
        x0 = float(self.envelope_(np.asarray(u[:1]))[0])
        return Chain.of(TanhGPI(_relaxed(p0, r, w, x0), self.envelope_), Offset(self.offset_))
