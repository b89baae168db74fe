"""Truth plants beyond the PI family for the missing-physics benchmark (notes §7.7, E10).

Every plant of :mod:`benchmarks.diagnosis.generator` is a Prandtl–Ishlinskii model
underneath; real actuators are not. This module adds base hysteresis families that the
diagnosis' PI baseline cannot represent exactly, the recordings a user would have of them,
the hidden effects of the benchmark applied after the base (``core.stages`` models), and
the parameter-recovery score of a diagnosis against the truth.

Base families (:data:`BASES`; input ``u`` in V over 0-150 V, output ``y`` in um, each scaled
by its ``gain`` so that a 0 → 150 → 0 V sweep spans :data:`STROKE` = 100 um):

``bouc-wen-1`` / ``-2`` / ``-3``
    rate-independent Bouc-Wen, :class:`BoucWen` (three parameter sets: n = 1, 2, 1.5 and
    different beta / gamma ratios).
``preisach``
    a relay bank with a density that depends on the bias (α + β)/2, :class:`Preisach`
    (non-congruent minor loops, E10).
``duhem``
    the rate-independent Coleman–Hodgdon Duhem model, :class:`Duhem`.
``maxwell-slip``
    elasto-slide elements in parallel plus a spring, :class:`MaxwellSlip` (a saturating,
    stop-type loop).
``menegotto-pinto``
    a uniaxial steel (strain in, stress out, clockwise loops) whose transition curvature
    depends on the previous plastic excursion, :class:`MenegottoPinto` (non-Masing).

Scenarios: :func:`make_family` ``(base, effect, size, noise, seed)`` → a
:class:`~benchmarks.diagnosis.generator.Scenario` with four recordings (slow sines, fast
sines, a decaying sine around mid range, an up-then-down staircase with holds; 68.5 k
samples), white noise, and at most one hidden effect at size ``"large"`` or ``"small"``
(:data:`FAMILY_EFFECTS`). Truth: ``scenario.params`` (the effect's parameters),
``extras["hidden"]`` (effect name → parameters), ``extras["base"]`` / ``["base_params"]``.

Scoring helpers: :func:`parameter_recovery` (found vs truth per parameter, with the reported
1-sigma uncertainty), :func:`wrong_names_base` (names that are wrong on a non-PI base).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numba import njit

from benchmarks.diagnosis.generator import Scenario
from core.base import Model
from core.recordings import Recording
from core.stages import Asymmetry, Creep, Delay, Drift, Lag, Offset, Resonance

__all__ = ["BASES", "CONCEALMENT_RECORDINGS", "FAMILY_EFFECTS", "MULTI_EFFECTS",
           "OPENSEES_DEV_BASES", "SIZES", "STAGE_ORDER", "STROKE",
           "TIME_EFFECTS", "BoucWen", "BoucWenBaberNoori", "Duhem", "MaxwellSlip",
           "MenegottoPinto", "Preisach",
           "family_signals", "make_base", "make_family", "parameter_recovery",
           "recovery_quantities", "within_sigmas", "wrong_names_base"]

U_MAX = 150.0  # V
STROKE = 100.0  # um, of a 0 -> 150 -> 0 V sweep after scaling


# ----------------------------------------------------------------------------- kernels
@njit(cache=True)
def _bw_rhs(z, s, alpha, beta, gamma, n):  # pragma: no cover - compiled
    sz = s * z
    sg = 1.0 if sz > 0.0 else (-1.0 if sz < 0.0 else 0.0)
    return alpha - (beta * sg + gamma) * abs(z) ** n


@njit(cache=True)
def _bouc_wen_z(u, alpha, beta, gamma, n, h, z0):  # pragma: no cover - compiled
    """z along the input path: RK4 in x with sub-steps of at most ``h`` input units."""
    z = z0
    out = np.empty(u.size)
    out[0] = z
    for k in range(1, u.size):
        du = u[k] - u[k - 1]
        if du != 0.0:
            m = max(1, int(math.ceil(abs(du) / h)))
            dx = du / m
            s = 1.0 if du > 0.0 else -1.0
            for _ in range(m):
                k1 = _bw_rhs(z, s, alpha, beta, gamma, n)
                k2 = _bw_rhs(z + 0.5 * dx * k1, s, alpha, beta, gamma, n)
                k3 = _bw_rhs(z + 0.5 * dx * k2, s, alpha, beta, gamma, n)
                k4 = _bw_rhs(z + dx * k3, s, alpha, beta, gamma, n)
                z += dx * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        out[k] = z
    return out


@njit(cache=True)
def _relays(u, rate, alpha, beta, w, state):  # pragma: no cover - compiled
    """Sum of w_i R_i[u] with relay i up (1) once u >= alpha_i + rate_k, down (0) once
    u <= beta_i - rate_k (``rate`` = beta_s |du/dt|, zero for the rate-independent bank)."""
    out = np.empty(u.size)
    for k in range(u.size):
        uk = u[k]
        r = rate[k]
        acc = 0.0
        for i in range(alpha.size):
            if uk >= alpha[i] + r:
                state[i] = 1
            elif uk <= beta[i] - r:
                state[i] = 0
            if state[i]:
                acc += w[i]
        out[k] = acc
    return out


@njit(cache=True)
def _duhem(u, a, alpha, b0, b2, uc, ur, h, y0):  # pragma: no cover - compiled
    """Coleman–Hodgdon dy/du = alpha sgn(du) (a u - y) + g(u), RK4 sub-steps in u."""
    y = y0
    out = np.empty(u.size)
    out[0] = y
    for k in range(1, u.size):
        du = u[k] - u[k - 1]
        if du != 0.0:
            m = max(1, int(math.ceil(abs(du) / h)))
            dx = du / m
            s = 1.0 if du > 0.0 else -1.0
            x = u[k - 1]
            for _ in range(m):
                c = (x - uc) / ur
                k1 = s * alpha * (a * x - y) + b0 + b2 * c * c
                xm = x + 0.5 * dx
                cm = (xm - uc) / ur
                gm = b0 + b2 * cm * cm
                k2 = s * alpha * (a * xm - (y + 0.5 * dx * k1)) + gm
                k3 = s * alpha * (a * xm - (y + 0.5 * dx * k2)) + gm
                xe = x + dx
                ce = (xe - uc) / ur
                k4 = s * alpha * (a * xe - (y + dx * k3)) + b0 + b2 * ce * ce
                y += dx * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
                x = xe
        out[k] = y
    return out


@njit(cache=True)
def _maxwell_slip(u, d, delta):  # pragma: no cover - compiled
    """Element deflections: delta_i follows du until |delta_i| = d_i (then it slides)."""
    out = np.empty((u.size, d.size))
    for k in range(u.size):
        du = u[k] - u[k - 1] if k > 0 else 0.0
        for i in range(d.size):
            v = delta[i] + du
            if v > d[i]:
                v = d[i]
            elif v < -d[i]:
                v = -d[i]
            delta[i] = v
            out[k, i] = v
    return out


@njit(cache=True)
def _menegotto_pinto(eps, e0, fy, b, r0, cr1, cr2):  # pragma: no cover - compiled
    """Stress along the strain path ``eps`` (see :class:`MenegottoPinto`), from the virgin
    state at zero strain and stress."""
    ey = fy / e0
    out = np.empty(eps.size)
    s = 0.0  # direction of the current branch (0: virgin, no branch yet)
    er, sr = 0.0, 0.0  # reversal point of the branch
    ea, sa = 0.0, 0.0  # where its two asymptotes meet
    rr = r0
    emax, emin = ey, -ey  # extreme strains reached in tension / compression
    prev, sig = 0.0, 0.0
    for k in range(eps.size):
        de = eps[k] - prev
        d = 1.0 if de > 0.0 else (-1.0 if de < 0.0 else 0.0)
        if d != 0.0 and d != s:
            if s != 0.0:  # a reversal at the previous sample: a new branch starts there
                if s > 0.0:
                    emax = max(emax, prev)
                else:
                    emin = min(emin, prev)
                er, sr = prev, sig
            # the elastic line from the reversal (slope E0) meets the hardening line
            # through (d ey, d fy) (slope b E0) at (ea, sa)
            ea = (d * fy * (1.0 - b) - sr + e0 * er) / (e0 * (1.0 - b))
            sa = d * fy + b * e0 * (ea - d * ey)
            xi = abs((emax if d > 0.0 else emin) - ea) / ey if s != 0.0 else 0.0
            rr = r0 * (1.0 - cr1 * xi / (cr2 + xi))
            s = d
        if s != 0.0:
            x = (eps[k] - er) / (ea - er)
            ax = abs(x)
            sig = sr + (sa - sr) * (b * x + (1.0 - b) * x / (1.0 + ax**rr) ** (1.0 / rr))
        out[k] = sig
        prev = eps[k]
    return out


@njit(cache=True)
def _bwbn_rhs(z, e, s, a, beta, gamma, n, dnu, deta, zs, p, q, psi0, dpsi, lam):
    # pragma: no cover - compiled
    """dz/dx and de/dx of the Bouc-Wen-Baber-Noori law (see :class:`BoucWenBaberNoori`)
    moving in direction ``s`` with hysteretic variable ``z`` and energy ``e``."""
    nu = 1.0 + dnu * e
    eta = 1.0 + deta * e
    zu = (a / (nu * (beta + gamma))) ** (1.0 / n)
    z1 = zs * (1.0 - math.exp(-p * e))
    z2 = (psi0 + dpsi * e) * (lam + z1)
    h = 1.0 - z1 * math.exp(-((z * s - q * zu) ** 2) / (z2 * z2))
    sz = s * z
    sg = 1.0 if sz > 0.0 else (-1.0 if sz < 0.0 else 0.0)
    return h * (a - nu * (beta * sg + gamma) * abs(z) ** n) / eta, z


@njit(cache=True)
def _bwbn(x, a, beta, gamma, n, dnu, deta, zs, p, q, psi0, dpsi, lam, h_x):
    # pragma: no cover - compiled
    """z along the displacement path ``x`` from the virgin state (z = 0, no energy): RK4 in
    x with sub-steps of at most ``h_x``, the energy integrated with it."""
    z, e = 0.0, 0.0
    out = np.empty(x.size)
    out[0] = z
    for k in range(1, x.size):
        dxk = x[k] - x[k - 1]
        if dxk != 0.0:
            m = max(1, int(math.ceil(abs(dxk) / h_x)))
            dx = dxk / m
            s = 1.0 if dxk > 0.0 else -1.0
            for _ in range(m):
                k1, l1 = _bwbn_rhs(z, e, s, a, beta, gamma, n, dnu, deta, zs, p, q, psi0,
                                   dpsi, lam)
                k2, l2 = _bwbn_rhs(z + 0.5 * dx * k1, e + 0.5 * dx * l1, s, a, beta, gamma,
                                   n, dnu, deta, zs, p, q, psi0, dpsi, lam)
                k3, l3 = _bwbn_rhs(z + 0.5 * dx * k2, e + 0.5 * dx * l2, s, a, beta, gamma,
                                   n, dnu, deta, zs, p, q, psi0, dpsi, lam)
                k4, l4 = _bwbn_rhs(z + dx * k3, e + dx * l3, s, a, beta, gamma, n, dnu, deta,
                                   zs, p, q, psi0, dpsi, lam)
                z += dx * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
                e += dx * (l1 + 2.0 * l2 + 2.0 * l3 + l4) / 6.0
        out[k] = z
    return out


# ----------------------------------------------------------------------------- base plants
@dataclass
class BoucWen:
    """Rate-independent Bouc-Wen actuator ``y = gain (k u - c z)``.

    The hysteretic variable follows the Bouc-Wen law written in the input, not in time,

        dz/du = alpha - (beta sign(du z) + gamma) |z|^n,

    integrated along the input path (RK4 with sub-steps of at most ``h_v`` V, so large input
    increments such as the ramped steps of a staircase are integrated accurately); the output
    therefore depends on the sequence of input values only (rate-independent). ``z``
    saturates at ``(alpha / (beta + gamma))^(1/n)``; ``beta > |gamma|`` gives the usual
    counter-clockwise piezo loop (``y`` below on the way up).

    Parameters
    ----------
    k : float
        Reversible slope (um/V before ``gain``).
    c : float
        Weight of the hysteretic variable (um/V before ``gain``).
    alpha : float
        Initial slope of z (dimensionless).
    beta, gamma : float
        Shape parameters (V^-n).
    n : float
        Smoothness exponent (dimensionless, >= 1).
    gain : float
        Output scale (dimensionless; :func:`make_base` sets it for a 100 um stroke).
    h_v : float
        Largest integration sub-step (V).
    z0 : float
        Initial hysteretic variable (V).
    """

    k: float
    c: float
    alpha: float
    beta: float
    gamma: float
    n: float
    gain: float = 1.0
    h_v: float = 0.25
    z0: float = 0.0

    def __call__(self, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        u = np.ascontiguousarray(u, dtype=np.float64)
        z = _bouc_wen_z(u, self.alpha, self.beta, self.gamma, self.n, self.h_v, self.z0)
        return self.gain * (self.k * u - self.c * z)


@dataclass
class Preisach:
    """General Preisach model: a bank of relays on a triangle grid plus a reversible term,

        y = gain (k_rev u + sum_{alpha_i > beta_i} mu(alpha_i, beta_i) R_{alpha_i beta_i}[u]),

    relay ``R`` switches up (1) when ``u >= alpha``, down (0) when ``u <= beta``, and keeps
    its state in between (all relays down at the start: the virgin state at 0 V). The grid is
    ``n_grid`` x ``n_grid`` cells over 0-150 V on each axis, one relay per cell below the
    diagonal (4950 relays for 100) at a fixed random point of its cell (``grid_seed``), so
    that the output has no visible steps where a whole row of relays would switch at once.
    The density depends on the bias ``m = (alpha + beta) / 2`` and the half-width
    ``r = (alpha - beta) / 2``,

        mu = exp(-r / width_v) (floor + exp(-((m - bias_v) / bias_width_v)^2)),

    centred off mid range, so minor loops of equal amplitude at different bias levels are
    not congruent (a PI's density depends on ``r`` only; notes E10).

    ``beta_s`` > 0 makes the relays rate-dependent (``alpha + beta_s |du/dt|`` up,
    ``beta - beta_s |du/dt|`` down, the Preisach analogue of the benchmark's
    ``RateDependentPI``; needs ``dt``); 0 is rate-independent.

    Parameters
    ----------
    k_rev : float
        Reversible slope (um/V before ``gain``).
    hyst : float
        Total relay weight (um before ``gain``; the weights are normalised to sum to it).
    width_v, bias_v, bias_width_v : float
        Density decay in the half-width, bias centre and bias width (V).
    floor : float
        Bias-independent part of the density (dimensionless).
    n_grid : int
        Grid cells per axis.
    grid_seed : int
        Seed of the relay positions inside their cells.
    beta_s : float
        Rate coefficient (s).
    gain : float
        Output scale (dimensionless).
    """

    k_rev: float = 0.5
    hyst: float = 55.0
    width_v: float = 25.0
    bias_v: float = 45.0
    bias_width_v: float = 40.0
    floor: float = 0.25
    n_grid: int = 100
    grid_seed: int = 7
    beta_s: float = 0.0
    gain: float = 1.0

    def grid(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(alpha, beta, weight)`` of every relay."""
        h = U_MAX / self.n_grid
        i, j = np.meshgrid(np.arange(self.n_grid), np.arange(self.n_grid), indexing="ij")
        keep = i > j
        # one relay per grid cell, at a fixed pseudo-random point of its cell (a stratified
        # grid: rows of relays do not all switch at one input value)
        jit = np.random.default_rng(self.grid_seed).uniform(0.0, 1.0, (2, int(keep.sum())))
        a, b = (i[keep] + jit[0]) * h, (j[keep] + jit[1]) * h
        r, m = (a - b) / 2, (a + b) / 2
        mu = np.exp(-r / self.width_v) * (self.floor
                                          + np.exp(-((m - self.bias_v) / self.bias_width_v) ** 2))
        return a, b, self.hyst * mu / mu.sum()

    def __call__(self, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        u = np.ascontiguousarray(u, dtype=np.float64)
        a, b, w = self.grid()
        if self.beta_s:
            if dt is None:
                raise ValueError("a rate-dependent Preisach needs dt")
            rate = self.beta_s * np.abs(np.gradient(u, dt))
        else:
            rate = np.zeros(u.size)
        y = _relays(u, rate, a, b, w, np.zeros(a.size, dtype=np.int8))
        return self.gain * (self.k_rev * u + y)


@dataclass
class Duhem:
    """Rate-independent Duhem model in the Coleman–Hodgdon form,

        dy/du = alpha sgn(du) (a u - y) + g(u),   g(u) = b0 + b2 ((u - uc) / ur)^2,

    integrated along the input path (RK4 sub-steps of at most ``h_v`` V), output
    ``gain * y``. After a reversal the branch relaxes exponentially (rate ``alpha`` per volt)
    towards the anhysteretic line shifted by ``±(a - g) / alpha``; minor loops need not close
    (no wiping-out property), unlike a PI or Preisach model.

    Parameters
    ----------
    a : float
        Slope of the anhysteretic line (um/V before ``gain``).
    alpha : float
        Relaxation rate (1/V).
    b0, b2 : float
        Branch slope at ``uc`` and its quadratic increase towards ``uc ± ur`` (um/V).
    uc, ur : float
        Centre and half-range of the slope variation (V).
    gain : float
        Output scale (dimensionless).
    h_v : float
        Largest integration sub-step (V).
    """

    a: float = 1.0
    alpha: float = 0.03
    b0: float = 0.72
    b2: float = 0.2
    uc: float = 75.0
    ur: float = 75.0
    gain: float = 1.0
    h_v: float = 0.25

    def __call__(self, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        u = np.ascontiguousarray(u, dtype=np.float64)
        y = _duhem(u, self.a, self.alpha, self.b0, self.b2, self.uc, self.ur, self.h_v,
                   0.0)
        return self.gain * y


@dataclass
class MaxwellSlip:
    """Maxwell-slip friction model: N elasto-slide elements in parallel with a spring,

        y = gain (k0 u + sum_i k_i delta_i),   d delta_i = du while |delta_i| < d_i,

    element ``i`` (stiffness ``k_i``, slip force ``F_i = k_i d_i``) deflects with the input
    until its deflection reaches ``±d_i`` and then slides. Each element is a stop operator,
    so the loop saturates: after a reversal the tangent stiffness is ``k0 + sum k_i`` and it
    drops to ``k0`` once every element slides (travel > ``2 max d_i``). In play form it is a
    PI with *negative* play weights, outside the diagnosis' monotone PI.

    Parameters
    ----------
    k0 : float
        Parallel spring (um/V before ``gain``).
    k : sequence of float
        Element stiffnesses (um/V before ``gain``).
    d : sequence of float
        Slip deflections (V of input travel).
    gain : float
        Output scale (dimensionless).
    """

    k0: float = 0.45
    k: tuple[float, ...] = (0.08, 0.07, 0.06, 0.05, 0.04, 0.035, 0.03, 0.025)
    d: tuple[float, ...] = (3.0, 6.0, 10.0, 15.0, 21.0, 28.0, 36.0, 45.0)
    gain: float = 1.0

    def __call__(self, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        u = np.ascontiguousarray(u, dtype=np.float64)
        d = np.asarray(self.d, dtype=np.float64)
        dl = _maxwell_slip(u, d, np.zeros(d.size))
        return self.gain * (self.k0 * u + dl @ np.asarray(self.k, dtype=np.float64))


@dataclass
class MenegottoPinto:
    """Uniaxial steel after Menegotto and Pinto (1973) with the transition curvature of
    Filippou, Popov and Bertero (1983) (the Giuffre-Menegotto-Pinto law): strain in, stress
    out, clockwise loops (the loading branch above the unloading one).

    The input is a strain ``eps = strain_max u / 150 V`` (0 V: zero strain, the virgin
    state). Each branch runs from its reversal point ``(eps_r, sig_r)`` towards the point
    ``(eps_0, sig_0)`` where the elastic line from the reversal (slope ``E0``) meets the
    hardening asymptote of the new direction (slope ``b E0`` through ``(±eps_y, ±fy)``,
    kinematic hardening, no isotropic hardening):

        sig* = b eps* + (1 - b) eps* / (1 + |eps*|^R)^(1/R),
        eps* = (eps - eps_r) / (eps_0 - eps_r),   sig* = (sig - sig_r) / (sig_0 - sig_r),

    with ``R = R0 (1 - cR1 xi / (cR2 + xi))`` (Filippou's ``R0 - a1 xi / (a2 + xi)``
    with ``a1 = cR1 R0``) and ``xi = |eps_m - eps_0| / eps_y``, ``eps_m`` the
    largest strain reached so far in the new branch's direction (``±eps_y`` before any
    excursion). The curvature of a branch thus depends on the previous plastic excursion
    (a non-Masing law, outside the PI family whose branches are scaled copies of one
    curve); the first loading from rest has ``R = R0``. Rate-independent: a reversal is
    where the strain increment changes sign, and the branch is an explicit function of the
    strain.

    Parameters
    ----------
    e0 : float
        Initial (elastic) modulus E0 (MPa).
    fy : float
        Yield stress (MPa).
    b : float
        Strain-hardening ratio (asymptotic slope over E0, dimensionless).
    r0, cr1, cr2 : float
        Transition curvature R0 and its decrease with the plastic excursion (dimensionless).
    strain_max : float
        Strain at 150 V (dimensionless).
    gain : float
        Output scale (um per MPa; :func:`make_base` sets it for a 100 um stroke).
    """

    e0: float = 200000.0
    fy: float = 400.0
    b: float = 0.015
    r0: float = 20.0
    cr1: float = 0.925
    cr2: float = 0.15
    strain_max: float = 0.01
    gain: float = 1.0

    def stress(self, eps: np.ndarray) -> np.ndarray:
        """Stress (MPa) along the strain history ``eps``, shape (n,)."""
        eps = np.ascontiguousarray(eps, dtype=np.float64)
        return _menegotto_pinto(eps, self.e0, self.fy, self.b, self.r0, self.cr1, self.cr2)

    def __call__(self, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        u = np.ascontiguousarray(u, dtype=np.float64)
        return self.gain * self.stress(self.strain_max * u / U_MAX)


@dataclass
class BoucWenBaberNoori:
    """A pinched structural element after Baber and Noori (1985, 1986) in the form of
    Foliente (1995) (the Bouc-Wen-Baber-Noori law): displacement in, restoring force out,
    clockwise loops (the loading branch above the unloading one) that narrow near zero
    hysteretic force.

    The input is a displacement ``x = x_max u / 150 V`` (0 V: the virgin state, z = 0). The
    force is ``F = alpha k x + (1 - alpha) k z`` with the hysteretic variable written in the
    displacement, not in time (rate-independent):

        dz/dx = h(z) [A - nu |z|^n (beta sign(dx z) + gamma)] / eta,
        h(z)  = 1 - zeta1 exp(-(z sign(dx) - q z_u)^2 / zeta2^2),
        z_u   = (A / (nu (beta + gamma)))^(1/n),
        zeta1 = zeta_s (1 - exp(-p e)),  zeta2 = (psi0 + delta_psi e) (lam + zeta1),
        nu    = 1 + delta_nu e,          eta = 1 + delta_eta e,

    with ``e = integral of z dx`` (the dissipated hysteretic energy per unit ``(1 - alpha)
    k``). ``h`` is the pinching function: where ``z sign(dx)`` passes ``q z_u`` (a branch
    crossing zero hysteretic force) the slope of ``z`` drops by the factor ``1 - zeta1``, so
    the force changes little there and the loop is pinched; ``zeta1`` grows with the energy,
    so the first loading from rest is not pinched. ``nu`` and ``eta`` (strength and
    stiffness degradation) are off by default (``delta_nu = delta_eta = delta_psi = 0``):
    with them the loop keeps shrinking from cycle to cycle, which the benchmark would have to
    count as a drift of its own. With the defaults ``zeta1`` reaches ``zeta_s`` within the
    first loading and the loop under a periodic input is closed from the second cycle on.

    Parameters
    ----------
    k : float
        Initial stiffness (kN/mm).
    alpha : float
        Post-yield stiffness ratio (dimensionless).
    a, beta, gamma, n : float
        Bouc-Wen shape: initial slope of z (dimensionless), ``beta``, ``gamma`` (mm^-n), the
        sharpness of the transition (dimensionless, >= 1).
    delta_nu, delta_eta : float
        Strength and stiffness degradation per unit energy (mm^-2).
    zeta_s, p, q, psi0, delta_psi, lam : float
        Pinching: its severity (0-1), its growth with energy (mm^-2), where it sits (a
        fraction of ``z_u``), its spread (mm) and the spread's growth with energy (mm^-1),
        and the spread's link to the severity (dimensionless).
    x_max : float
        Displacement at 150 V (mm).
    gain : float
        Output scale (um per kN; :func:`make_base` sets it for a 100 um stroke).
    h_x : float
        Largest integration sub-step (mm).
    """

    k: float = 1.0
    alpha: float = 0.05
    a: float = 1.0
    beta: float = 0.07
    gamma: float = 0.03
    n: float = 1.0
    delta_nu: float = 0.0
    delta_eta: float = 0.0
    zeta_s: float = 0.9
    p: float = 0.1
    q: float = 0.02
    psi0: float = 2.5
    delta_psi: float = 0.0
    lam: float = 0.5
    x_max: float = 60.0
    gain: float = 1.0
    h_x: float = 0.05

    def z(self, x: np.ndarray) -> np.ndarray:
        """The hysteretic variable (mm) along the displacement history ``x`` (mm)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        return _bwbn(x, self.a, self.beta, self.gamma, self.n, self.delta_nu,
                     self.delta_eta, self.zeta_s, self.p, self.q, self.psi0, self.delta_psi,
                     self.lam, self.h_x)

    def force(self, x: np.ndarray) -> np.ndarray:
        """Restoring force (kN) along the displacement history ``x`` (mm), shape (n,)."""
        x = np.ascontiguousarray(x, dtype=np.float64)
        return self.k * (self.alpha * x + (1.0 - self.alpha) * self.z(x))

    def __call__(self, u: np.ndarray, dt: float | None = None) -> np.ndarray:
        u = np.ascontiguousarray(u, dtype=np.float64)
        return self.gain * self.force(self.x_max * u / U_MAX)


#: Base family name -> unscaled plant (``make_base`` scales it to a 100 um stroke).
BASES: dict[str, Any] = {
    "bouc-wen-1": lambda: BoucWen(k=1.0, c=0.4, alpha=1.0, beta=0.03, gamma=0.01, n=1.0),
    "bouc-wen-2": lambda: BoucWen(k=1.0, c=0.3, alpha=1.0, beta=4e-4, gamma=-1e-4, n=2.0),
    "bouc-wen-3": lambda: BoucWen(k=1.0, c=0.35, alpha=1.0, beta=0.004, gamma=0.002, n=1.5),
    "preisach": lambda: Preisach(),
    "duhem": lambda: Duhem(),
    "maxwell-slip": lambda: MaxwellSlip(),
    "menegotto-pinto": lambda: MenegottoPinto(),
    "bouc-wen-baber-noori": lambda: BoucWenBaberNoori(),
}
#: Development plants from an independent implementation (OpenSees through openseespy, a dev
#: extra): the laws of the sealed set with other parameters
#: (:data:`benchmarks.diagnosis.opensees_plants.DEV_MATERIALS`), driven ±150 V -> ±6 mm/m.
#: Not in :data:`BASES` (the family classes of ``classes.py`` run every base there); only the
#: bipolar recordings drive them (:mod:`benchmarks.diagnosis.bipolar`).
OPENSEES_DEV_BASES = ("os-boucwen-dev", "os-steel02-dev", "os-pinched-dev")


def _unscaled(name: str) -> Any:
    if name in OPENSEES_DEV_BASES:
        from benchmarks.diagnosis.opensees_plants import StrainDriven

        return StrainDriven(name)
    if name not in BASES:
        raise ValueError(f"unknown base {name!r}; known: "
                         f"{', '.join((*BASES, *OPENSEES_DEV_BASES))}")
    return BASES[name]()


def _sweep() -> np.ndarray:
    return np.concatenate((np.linspace(0, U_MAX, 601), np.linspace(U_MAX, 0, 601)[1:]))


def make_base(name: str, **overrides: Any) -> Any:
    """The base plant ``name`` of :data:`BASES` or :data:`OPENSEES_DEV_BASES` (``overrides``
    replace its parameters), with ``gain`` set so that a 0 → 150 → 0 V sweep spans
    :data:`STROKE` um."""
    p = _unscaled(name)
    for k, v in overrides.items():
        setattr(p, k, v)
    p.gain = 1.0
    p.gain = STROKE / float(np.ptp(p(_sweep(), dt=1e-3)))
    return p


# ----------------------------------------------------------------------------- recordings
def family_signals() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The four recordings ``(name, t, u)``: 68.5 k samples in all.

    ``slow``: 3 cycles of a full-stroke 1 Hz cosine (0-150 V), 2 kHz, 3 s;
    ``fast``: full-stroke cosines, 10 cycles at 20 Hz, 25 at 50 Hz, 50 at 100 Hz, 10 kHz, 1.5 s;
    ``decaying``: a 1 Hz cosine around 75 V, amplitude 75 V e^(-t/3), 2.5 kHz, 8 s;
    ``staircase``: 0 → 150 → 0 V in 30 V steps ramped over 5 ms, 2.5 s holds, 1 kHz, 27.5 s.
    """
    out = []
    fs = 2000.0
    t = np.arange(0, 3.0, 1 / fs)
    out.append(("slow", t, 75.0 - 75.0 * np.cos(2 * np.pi * t)))
    fs = 10000.0
    segs = []
    for f, cyc in ((20.0, 10), (50.0, 25), (100.0, 50)):
        tt = np.arange(0, cyc / f, 1 / fs)
        segs.append(75.0 - 75.0 * np.cos(2 * np.pi * f * tt))
    u = np.concatenate(segs)
    out.append(("fast", np.arange(u.size) / fs, u))
    fs = 2500.0
    t = np.arange(0, 8.0, 1 / fs)
    out.append(("decaying", t, 75.0 - 75.0 * np.exp(-t / 3.0) * np.cos(2 * np.pi * t)))
    fs = 1000.0
    parts, prev = [], 0.0
    for lv in (0, 30, 60, 90, 120, 150, 120, 90, 60, 30, 0):
        parts.append(np.linspace(prev, lv, 6)[1:])
        parts.append(np.full(int(2.5 * fs) - 5, float(lv)))
        prev = float(lv)
    u = np.concatenate(parts)
    out.append(("staircase", np.arange(u.size) / fs, u))
    return out


# ----------------------------------------------------------------------------- hidden effects
#: Recordings over which a scenario's ``concealment_pct`` is measured: the slow, full-stroke
#: ones (here and in :mod:`benchmarks.diagnosis.bipolar`).
CONCEALMENT_RECORDINGS = ("slow", "decaying", "growing")
SIZES = ("large", "small", "eighth")
#: Creep lags (s) and the total creep fraction at size "large" (split equally).
CREEP_TAUS = (0.005, 0.1, 5.0)

#: Hidden effect -> size -> truth parameters. "small" is about a third of "large" (the
#: resonance by its quasi-static error, which goes as (f / f_n)^2: f_n x sqrt(3)); "eighth"
#: (delay, lag and resonance only) an eighth of "large" (resonance: f_n x sqrt(8)).
FAMILY_EFFECTS: dict[str, dict[str, dict[str, Any]]] = {
    "creep": {"large": {"taus_s": list(CREEP_TAUS), "weights": [0.02, 0.02, 0.02]},
              "small": {"taus_s": list(CREEP_TAUS), "weights": [0.02 / 3] * 3}},
    "delay": {"large": {"delay_s": 1e-3}, "small": {"delay_s": 1e-3 / 3},
              "eighth": {"delay_s": 1e-3 / 8}},
    "lag": {"large": {"tau_s": 1e-3}, "small": {"tau_s": 1e-3 / 3},
            "eighth": {"tau_s": 1e-3 / 8}},
    "resonance": {"large": {"freq_hz": 200.0, "damping": 0.05},
                  "small": {"freq_hz": 200.0 * math.sqrt(3.0), "damping": 0.05},
                  "eighth": {"freq_hz": 200.0 * math.sqrt(8.0), "damping": 0.05}},
    "rate": {"large": {"beta_s": 3e-4}, "small": {"beta_s": 1e-4}},
    "drift": {"large": {"amplitude": 1.0}, "small": {"amplitude": 1.0 / 3}},
}
#: Effects that exist only as members of a multi-effect scenario (``make_family`` with
#: ``"a+b+c"``; not in :data:`FAMILY_EFFECTS`, so the single-effect cases are unchanged):
#: a quadratic output map (``a2`` um at the ends of the 0-100 um range) and a per-recording
#: output offset (``spread`` x (-1, +1, +0.3, -0.5) um for slow, fast, decaying, staircase).
MULTI_EFFECTS: dict[str, dict[str, dict[str, Any]]] = {
    "asymmetry": {"large": {"a2": 1.5}},
    "offset": {"large": {"spread": 1.0}},
}
#: Physical order of the hidden stages after the base: output map, slow effects, dynamics,
#: sensor offset, drift (the order of ``generator._plant_of``).
STAGE_ORDER = ("asymmetry", "creep", "delay", "lag", "resonance", "offset", "drift")
_OFFSET_SIGNS = (-1.0, 1.0, 0.3, -0.5)

#: Bases for which a rate effect is meaningful (the relays' thresholds widen with rate, as the
#: PI's plays do in ``RateDependentPI``); for the others ``rate`` is skipped.
RATE_BASES = ("preisach",)


def _effect_stage(effect: str, lv: dict[str, Any], t: np.ndarray,
                  rng: np.random.Generator, k: int = 0) -> Model:
    if effect == "creep":
        return Creep(lv["taus_s"], lv["weights"])
    if effect == "delay":
        return Delay(lv["delay_s"])
    if effect == "lag":
        return Lag(lv["tau_s"])
    if effect == "resonance":
        return Resonance(lv["freq_hz"], lv["damping"])
    if effect == "drift":
        span = float(t[-1] - t[0])
        s = 2 * (t - t[0]) / span - 1
        d = lv["amplitude"] * (0.5 * s + 0.3 * np.sin(1.3 * s + rng.uniform(0, 2)))
        return Drift(np.polynomial.legendre.legfit(s, d, 4)[1:], span)
    if effect == "asymmetry":
        return Asymmetry([lv["a2"], 0.0], 0.5 * STROKE, 0.5 * STROKE * 1.05)
    if effect == "offset":
        return Offset(lv["spread"] * _OFFSET_SIGNS[k % len(_OFFSET_SIGNS)])
    raise ValueError(f"unknown effect {effect!r}")


def _hidden_of(effect: str | None, size: str) -> dict[str, dict[str, Any]]:
    """Effect name(s) -> truth parameters; ``effect`` is one name or several joined by
    ``+`` (every one at ``size``, or at ``"large"`` when it has no ``size``)."""
    if effect in (None, "null"):
        return {}
    names = effect.split("+")
    if len(set(names)) != len(names):
        raise ValueError(f"effect {effect!r} names an effect twice")
    out = {}
    for e in names:
        table = FAMILY_EFFECTS.get(e) or (MULTI_EFFECTS.get(e) if len(names) > 1 else None)
        if table is None:
            known = ", ".join(FAMILY_EFFECTS) + (
                "; in a combination also " + ", ".join(MULTI_EFFECTS))
            raise ValueError(f"unknown effect {e!r}; known: {known}")
        if size not in table and len(names) == 1:
            raise ValueError(f"effect {e!r} has no size {size!r}; known: {', '.join(table)}")
        out[e] = dict(table.get(size, table["large"]))
    return out


def make_family(base: str, effect: str | None = None, size: str = "large",
                noise: float = 0.002, seed: int = 0,
                signals: list[tuple[str, np.ndarray, np.ndarray]] | None = None,
                concealed_over: tuple[str, ...] = CONCEALMENT_RECORDINGS) -> Scenario:
    """The four recordings of :func:`family_signals` (or ``signals``, ``(name, t, u)`` each,
    ``t`` in s and ``u`` in V) through base family ``base`` followed by the hidden
    ``effect`` (``None`` or ``"null"``: none) at ``size``.

    ``effect`` is one name of :data:`FAMILY_EFFECTS` or several joined by ``+`` (also
    :data:`MULTI_EFFECTS`; applied in :data:`STAGE_ORDER`, each at ``size`` where it has that
    size and at ``"large"`` otherwise; ``rate`` only alone). ``noise`` is the white noise
    sigma as a fraction of the stroke (0.002: 0.2 um). The noise depends on ``seed`` only
    (its own stream), the drift's wander phase on a second stream. ``concealment_pct`` is the
    max |effect| over the recordings named in ``concealed_over`` (by default
    :data:`CONCEALMENT_RECORDINGS`) in % of the stroke. ``extras``:
    ``hidden`` (name -> truth parameters), ``base``, ``base_params``, ``size``, ``family_id``
    (``base/effect/size/seed``).
    """
    effect = None if effect in (None, "null") else effect
    if size not in SIZES:
        raise ValueError(f"unknown size {size!r}; known: {', '.join(SIZES)}")
    hidden = _hidden_of(effect, size)
    if "rate" in hidden and len(hidden) > 1:
        raise ValueError("rate is a base-plant change and cannot be combined with other effects")
    if effect == "rate" and base not in RATE_BASES:
        raise ValueError(f"rate is not meaningful for base {base!r} (only {RATE_BASES})")
    order = [e for e in STAGE_ORDER if e in hidden]
    lv = hidden[effect] if len(hidden) == 1 else {
        f"{e}.{k}": v for e in order for k, v in hidden[e].items()}
    plant = make_base(base)
    rng_noise = np.random.default_rng([seed, 0])
    rng_drift = np.random.default_rng([seed, 1])
    sigma = noise * STROKE
    recs, truths, worst = [], [], 0.0
    for k, (name, t, u) in enumerate(family_signals() if signals is None else signals):
        dt = float(t[1] - t[0])
        y0 = plant(u, dt=dt)
        if effect == "rate":
            p_rate = make_base(base, beta_s=lv["beta_s"])
            p_rate.gain = plant.gain
            y_clean = p_rate(u, dt=dt)
            truths.append(p_rate)
        elif hidden:
            stages = [_effect_stage(e, hidden[e], t, rng_drift, k) for e in order]
            y_clean = y0
            for stage in stages:
                y_clean = stage(y_clean, dt=dt)
            truths.append((plant, *stages))
        else:
            y_clean = y0
            truths.append(plant)
        if name in concealed_over:
            worst = max(worst, float(np.max(np.abs(y_clean - y0))) / STROKE * 100)
        y = y_clean + sigma * rng_noise.standard_normal(u.size)
        recs.append(Recording(t, u, y, name))
    base_params = {k: (list(v) if isinstance(v, tuple) else v)
                   for k, v in asdict(plant).items()}
    return Scenario(effect, f"white{100 * noise:g}%", seed, size if effect else "-", lv, recs,
                    truths, worst,
                    extras={"hidden": hidden, "base": base,
                            "base_params": base_params, "size": size,
                            "family_id": f"{base}/{effect or 'null'}/"
                                         f"{size if effect else '-'}/{seed}"})


# ----------------------------------------------------------------------------- scoring
#: Dynamic / time effects: naming one that is not hidden is wrong on any base. Loop-shape
#: names (saturation, dead-zone, asymmetry) and a level-dependent memory are the base-class
#: difference and are not counted as wrong on a non-PI base.
TIME_EFFECTS = ("delay", "lag", "resonance", "rate", "creep", "drift", "offset",
                "initial-memory")


def wrong_names_base(found: list[str], hidden: list[str],
                     ambiguous_with_hidden: Any = None) -> list[str]:
    """Accepted dynamic/time effects that are not hidden (and, with
    ``ambiguous_with_hidden(name)``, not reported ambiguous with a hidden one)."""
    return [n for n in found if n in TIME_EFFECTS and n not in hidden
            and not (ambiguous_with_hidden is not None and ambiguous_with_hidden(n))]


def _num(x: Any) -> float | None:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def recovery_quantities(effect: str, params: dict[str, Any],
                        unc: dict[str, Any] | None = None
                        ) -> dict[str, tuple[float | None, float | None]]:
    """Comparable quantities of an effect, ``{quantity: (value, 1-sigma or None)}``.

    delay ``delay_s``; lag ``tau_s``; resonance ``freq_hz`` and ``damping``; rate ``beta_s``;
    creep ``creep_total`` = the sum of the lag weights (the fraction of a step that creeps;
    its sigma from the diagnosis' ``gamma_per_decade`` sigma times the number of lags, or the
    weights' sigmas in quadrature). Truth creep given as ``gamma`` per lag over the
    generator's five lags is converted the same way.
    """
    unc = unc or {}
    out: dict[str, tuple[float | None, float | None]] = {}
    if effect == "creep":
        w = params.get("weights")
        if w is not None:
            total = float(np.sum(w))
            n = len(w)
        elif "gamma" in params:  # generator truth: gamma per lag, five lags
            n = 5
            total = float(params["gamma"]) * n
        else:
            return out
        s = _num(unc.get("gamma_per_decade"))
        if s is not None and "gamma_per_decade" in params and "taus_s" in params:
            s = s * len(params["taus_s"])
        elif isinstance(unc.get("weights"), (list, tuple)):
            s = float(np.sqrt(np.sum(np.square(unc["weights"]))))
        else:
            s = None
        out["creep_total"] = (total, s)
        return out
    keys = {"delay": ("delay_s",), "lag": ("tau_s",), "resonance": ("freq_hz", "damping"),
            "rate": ("beta_s",)}.get(effect, ())
    for k in keys:
        if k in params:
            out[k] = (_num(params[k]), _num(unc.get(k)))
    return out


def within_sigmas(q: dict[str, Any], k: float) -> bool | None:
    """Whether a recovery row's ``found`` is within ``k`` of its reported ``sigma`` of the
    ``truth`` (``None`` without a sigma); computed from the numbers, so result files written
    before ``within_2sigma`` was kept read the same."""
    s = q["sigma"]
    return None if s is None else bool(abs(q["found"] - q["truth"]) <= k * s)


def parameter_recovery(claims: list[dict[str, Any]], hidden: dict[str, dict[str, Any]]
                       ) -> list[dict[str, Any]]:
    """One row per parameter of every accepted effect that is hidden: ``effect``,
    ``quantity``, ``truth``, ``found``, ``sigma`` (the reported 1-sigma or None),
    ``rel_err`` = (found - truth) / truth, ``within`` = |found - truth| <= sigma (None
    without a sigma), ``within_2sigma`` = |found - truth| <= 2 sigma (a calibrated sigma
    covers the truth in 68 % of runs at 1 sigma, 95 % at 2), ``ambiguous`` (the diagnosis
    said the parameter is ambiguous rather than a number), ``honest`` = within or
    ambiguous. ``claims``: dicts with ``name``, ``parameters``, ``uncertainty`` and
    optionally ``ambiguous_parameters``."""
    rows = []
    for c in claims:
        name = c["name"]
        if name not in hidden:
            continue
        truth = recovery_quantities(name, hidden[name])
        found = recovery_quantities(name, c.get("parameters") or {}, c.get("uncertainty"))
        amb = set(c.get("ambiguous_parameters") or ())
        for q, (tv, _) in truth.items():
            fv, s = found.get(q, (None, None))
            if tv is None or fv is None:
                continue
            row = {"effect": name, "quantity": q, "truth": tv, "found": fv, "sigma": s}
            within = within_sigmas(row, 1.0)
            ambiguous = q in amb
            rows.append({**row, "rel_err": (fv - tv) / tv if tv else None, "within": within,
                         "within_2sigma": within_sigmas(row, 2.0),
                         "ambiguous": ambiguous,
                         "honest": True if ambiguous else within})
    return rows



def jsonable(x: Any) -> Any:
    """Numbers, lists and mappings of ``x`` as plain JSON types (numpy converted)."""
    if isinstance(x, Mapping):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [jsonable(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return float(x)
    if isinstance(x, (np.integer, int)) and not isinstance(x, bool):
        return int(x)
    if isinstance(x, (str, bool)) or x is None:
        return x
    return str(x)
