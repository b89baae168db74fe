"""Statistics robust to coloured residuals: held-out loss comparison, score test, whiteness."""

from __future__ import annotations

from dataclasses import dataclass
from math import erf, sqrt

import numpy as np

from .._typing import Float1D
from ..fitting.adequacy import noise_floor  # the one white-noise floor (hyst fit's too)

__all__ = [
    "HELDOUT_BATCHES",
    "MIN_BATCHES",
    "MIN_BATCH_ROWS",
    "HeldOut",
    "heldout_comparison",
    "ljung_box",
    "newey_west_var",
    "noise_floor",
    "score_test",
    "signed_rank_p",
    "with_where",
]


@dataclass(frozen=True)
class HeldOut:
    """Held-out comparison of two models on the same test rows.

    Attributes
    ----------
    mse_before, mse_after : float
        Mean squared errors (output units²).
    gain : float
        Relative MSE reduction ``1 - mse_after / mse_before``.
    z : float
        Diebold–Mariano statistic of the squared-error differences with a batch-means
        (autocorrelation-robust) variance; ~N(0, 1) under equal accuracy.
    sign_p : float
        One-sided p-value of the Wilcoxon signed-rank test of the batch means (robust when
        the improvement is concentrated in a few batches, where DM is conservative).
    n_batches : int
    se : float
        Standard error of the mean squared-error difference (output units²) from the batch
        means, widened for their lag-1 autocorrelation (batches too short to be independent);
        NaN where not computed from batches.
    n_independent : float
        Effective number of independent batches, ``n_batches (1 - r1) / (1 + r1)`` with
        ``r1`` the lag-1 autocorrelation of the batch means (corrected for its small-sample
        bias and clipped to ``[0, 1)``, :func:`_independent_batches`); NaN where not
        computed from batches.
    """

    mse_before: float
    mse_after: float
    gain: float
    z: float
    sign_p: float
    n_batches: int
    se: float = float("nan")
    n_independent: float = float("nan")

    @property
    def p_value(self) -> float:
        """One-sided normal p-value of ``z``."""
        return 0.5 * (1.0 - erf(self.z / sqrt(2.0)))


#: Batches the held-out loss differences are cut into by default (:func:`heldout_comparison`),
#: at least :data:`MIN_BATCHES` and each at least :data:`MIN_BATCH_ROWS` rows long where the
#: rows allow.
HELDOUT_BATCHES = 40
MIN_BATCHES = 4
MIN_BATCH_ROWS = 10


def heldout_comparison(
    e_before: list[Float1D], e_after: list[Float1D], n_batches: int = HELDOUT_BATCHES
) -> HeldOut:
    """Compare squared-error losses of two models on held-out residuals.

    The loss differences ``d = e_before² - e_after²`` are cut into ``n_batches`` contiguous
    batches (per recording, in time order); the batch means are nearly independent when the
    batches are much longer than the residual correlation time, so the t-ratio of their mean
    is a HAC (batch-means) Diebold–Mariano statistic.

    Parameters
    ----------
    e_before, e_after : list of ndarray
        Held-out residual segments (same lengths pairwise).
    """
    d = np.concatenate([a * a - b * b for a, b in zip(e_before, e_after, strict=True)])
    mb = float(np.mean(np.concatenate(e_before) ** 2))
    ma = float(np.mean(np.concatenate(e_after) ** 2))
    nb = int(max(MIN_BATCHES, min(n_batches, d.size // MIN_BATCH_ROWS)))
    edges = np.linspace(0, d.size, nb + 1).astype(int)
    means = np.array([d[edges[i] : edges[i + 1]].mean() for i in range(nb)])
    sd = float(np.std(means, ddof=1))
    if sd > 0:
        z = float(np.mean(means) / (sd / np.sqrt(nb)))
    else:
        z = np.inf if means.mean() > 0 else 0.0
    sign_p = signed_rank_p(means)
    gain = 1.0 - ma / mb if mb > 0 else 0.0
    n_ind = _independent_batches(means)
    se = sd / np.sqrt(n_ind) if n_ind > 0 else float("nan")
    return HeldOut(mb, ma, gain, z, sign_p, nb, se, n_ind)


def _independent_batches(means: np.ndarray) -> float:
    """Effective number of independent batch means ``n (1 - r1) / (1 + r1)``, ``r1`` their
    lag-1 autocorrelation, bias-corrected and clipped to ``[0, 0.99]`` (an AR(1)
    approximation of the variance of their mean); ``means``: shape ``(n,)``.

    The sample lag-1 autocorrelation of ``n`` values about their own mean is biased low,
    ``E r ~ rho - (1 + 4 rho) / n`` (Kendall's approximation for an AR(1)); with 10-40
    batches that is 0.03-0.3 too low, so the batches counted independent were too many and
    the upper bound of :func:`~core.diagnosis.acceptance.harm_bound` too tight. Simulated
    AR(1) batch means (rho 0-0.6, n 10-40, 20,000 draws a cell): with the estimate
    ``(n r + 1) / (n - 4)`` the effective count is within 0.4 of the true one (before up to
    2.9 too many) and the one-sided 95 % bound covers 93-97 % (before 88-94 %); independent
    batch means are counted slightly fewer (n 40: 35.5). ``tests/core/diagnosis/test_stats.py``
    checks the count against the exact AR(1) effective number and the coverage (93-97 %
    correlated, 95-97.5 % independent). With 4 batches or fewer it stays uncorrected.
    """
    n = means.size
    c = means - means.mean()
    den = float(c @ c)
    r1 = float(c[1:] @ c[:-1]) / den if den > 0 and n > 2 else 0.0
    if n > 4 and den > 0:
        r1 = (n * r1 + 1.0) / (n - 4.0)
    r1 = min(max(r1, 0.0), 0.99)
    return n * (1.0 - r1) / (1.0 + r1)


def with_where(h: HeldOut, hw: HeldOut) -> HeldOut:
    """``h`` (the comparison on all the rows) also tested on the rows where the effect changes
    the prediction most (``hw``): the larger of the two z and twice the smaller signed-rank p
    (two tests, Bonferroni; at most 1), the effect size and batches of ``h``; ``h`` itself
    when ``hw`` is not finite."""
    if not (np.isfinite(hw.z) and np.isfinite(hw.sign_p)):
        return h
    return HeldOut(h.mse_before, h.mse_after, h.gain, max(h.z, hw.z),
                   min(1.0, 2.0 * min(h.sign_p, hw.sign_p)), h.n_batches, h.se, h.n_independent)


def signed_rank_p(x: np.ndarray) -> float:
    """One-sided (greater than zero) Wilcoxon signed-rank p-value of ``x``."""
    from scipy.stats import wilcoxon

    x = np.asarray(x, dtype=np.float64)
    x = x[x != 0]
    if x.size < 4:
        return 1.0
    return float(wilcoxon(x, alternative="greater").pvalue)


def newey_west_var(x: np.ndarray, lags: int) -> np.ndarray:
    """Newey–West (Bartlett) long-run covariance of the rows of ``x`` (shape (N, q))."""
    x = np.atleast_2d(x.T).T
    x = x - x.mean(axis=0)
    n = x.shape[0]
    S = x.T @ x / n
    for L in range(1, lags + 1):
        G = x[L:].T @ x[:-L] / n
        S += (1 - L / (lags + 1)) * (G + G.T)
    return S


def score_test(
    e: Float1D, J0: np.ndarray, psi: np.ndarray, lags: int
) -> tuple[float, int]:
    """Score (LM) test of ``e`` on ``psi`` with the base Jacobian ``J0`` partialled out.

    Frisch–Waugh–Lovell: regress ``e`` and ``psi`` on ``J0``; the statistic is
    ``g' V^-1 g`` with ``g = psi_r' e_r / N`` and ``V`` the Newey–West long-run covariance of
    ``psi_r * e_r``, ~χ²_q under "no effect" with coloured residuals.

    Returns
    -------
    stat : float
    q : int
        Degrees of freedom (columns of ``psi``).
    """
    psi = np.atleast_2d(psi.T).T
    coef = np.linalg.lstsq(J0, np.column_stack((e, psi)), rcond=None)[0]
    R = np.column_stack((e, psi)) - J0 @ coef
    er, pr = R[:, 0], R[:, 1:]
    n = er.size
    g = pr.T @ er / n
    V = newey_west_var(pr * er[:, None], lags) / n
    try:
        stat = float(g @ np.linalg.solve(V + 1e-300 * np.eye(V.shape[0]), g))
    except np.linalg.LinAlgError:
        stat = float("nan")
    return stat, psi.shape[1]


def ljung_box(e: Float1D, h: int = 20) -> tuple[float, int]:
    """Ljung–Box Q statistic of ``e`` over ``h`` lags (~χ²_h for white residuals)."""
    e = e - e.mean()
    n = e.size
    c0 = float(e @ e)
    if c0 == 0 or n <= h + 1:
        return 0.0, h
    q = sum((float(e[k:] @ e[:-k]) / c0) ** 2 / (n - k) for k in range(1, h + 1))
    return float(n * (n + 2) * q), h
