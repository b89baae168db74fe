"""Compiled play-operator kernels (numba, ``cache=True``).

Loop order is time outer, operators inner (row-major ``(N, n)`` outputs), which lets
LLVM vectorise across the independent operators (see ``shared/notes/perf-baseline.md``).
Every kernel takes the operator state before the first sample and returns the state
after the last, so long or streamed records can be processed in chunks.

The Preisach kernels (:func:`preisach_output`, :func:`preisach_inverse`, model in
:mod:`core.preisach`) run the same play update and sum each play's piecewise-linear level
function ``F_i(z) = sum_j W[i, j] seg_j(z)`` sequentially.

Two PI-output kernels exist:

* :func:`pi_output_fast` sums the weighted operators with ``fastmath={'reassoc'}`` so the
  dot product vectorises (about 0.25 ns per operator-update); results may differ from a
  sequential sum at the 1e-16 relative level.
* :func:`pi_output_strict` sums sequentially; it is bit-identical to the numpy oracle in
  :mod:`core.reference`.

The Bouc-Wen kernel (:func:`bouc_wen_bank`, model in :mod:`core.boucwen`) integrates a bank of
rate-independent Bouc-Wen elements along the input path with RK4 sub-steps.

The play update is ``z = max(u - r, min(u + r, z))`` (paper 001 eq. 1), written with
comparisons only, so the operator matrix is bit-identical to any other implementation.
"""

from __future__ import annotations

import math
import os

__all__ = [
    "NUMBA_ENABLED",
    "bouc_wen_bank",
    "bouc_wen_inverse",
    "bouc_wen_output",
    "stop_gap_output",
    "pi_batch",
    "pi_output_fast",
    "level_segments_rows",
    "mp_advance",
    "mp_inverse",
    "mp_elements",
    "mp_output",
    "mp_unit",
    "pi_output_strict",
    "play_matrix",
    "preisach_inverse",
    "preisach_output",
]

NUMBA_ENABLED = os.environ.get("HYST_DISABLE_NUMBA", "") not in ("1", "true", "yes")

if NUMBA_ENABLED:
    from numba import njit
else:  # pragma: no cover - exercised only when numba is disabled on purpose

    def njit(*args, **kwargs):
        if args and callable(args[0]):
            return args[0]
        return lambda f: f


@njit(cache=True, nogil=True, inline="always")
def play_update(zi, x, r):  # pragma: no cover - compiled
    """One play operator's step: its output ``zi`` held inside ``[x - r, x + r]``."""
    if zi > x + r:
        zi = x + r
    if zi < x - r:
        zi = x - r
    return zi


@njit(cache=True, nogil=True)
def play_matrix(u, r, z, out):  # pragma: no cover - compiled
    """Play-operator outputs for every sample and operator.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input samples.
    r : ndarray of shape (n,)
        Thresholds, ``r >= 0``.
    z : ndarray of shape (n,)
        Operator outputs before the first sample; updated in place to the final state.
    out : ndarray of shape (N, n)
        C-contiguous buffer written with the operator outputs.
    """
    N = u.shape[0]
    n = r.shape[0]
    for k in range(N):
        uk = u[k]
        for i in range(n):
            zi = play_update(z[i], uk, r[i])
            z[i] = zi
            out[k, i] = zi


@njit(cache=True, nogil=True)
def pi_output_strict(u, r, w, p0, z, out):  # pragma: no cover - compiled
    """PI output ``p0*u + sum_i w_i * play_i`` summed sequentially (deterministic).

    Parameters
    ----------
    u : ndarray of shape (N,)
    r, w : ndarray of shape (n,)
        Thresholds and weights.
    p0 : float
        Weight of the linear term.
    z : ndarray of shape (n,)
        Operator state, updated in place.
    out : ndarray of shape (N,)
    """
    N = u.shape[0]
    n = r.shape[0]
    for k in range(N):
        uk = u[k]
        acc = 0.0
        for i in range(n):
            zi = play_update(z[i], uk, r[i])
            z[i] = zi
            acc += w[i] * zi
        out[k] = p0 * uk + acc


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def pi_output_fast(u, r, w, p0, z, out):  # pragma: no cover - compiled
    """Same as :func:`pi_output_strict` but the sum may be reassociated (vectorised)."""
    N = u.shape[0]
    n = r.shape[0]
    for k in range(N):
        uk = u[k]
        acc = 0.0
        for i in range(n):
            lo = uk - r[i]
            hi = uk + r[i]
            zi = z[i]
            zi = min(zi, hi)
            zi = max(zi, lo)
            z[i] = zi
            acc += w[i] * zi
        out[k] = p0 * uk + acc


@njit(cache=True, nogil=True)
def _stop_force(v, r, w, k, z):  # pragma: no cover - compiled
    acc = k * v
    for i in range(r.shape[0]):
        acc += w[i] * (v - z[i])
    return acc


@njit(cache=True, nogil=True)
def _clip_plays(v, r, z):  # pragma: no cover - compiled
    for i in range(r.shape[0]):
        z[i] = max(v - r[i], min(v + r[i], z[i]))


@njit(cache=True, nogil=True)
def _branch_zero(v0, v1, r, w, k, z, side):  # pragma: no cover - compiled
    """Where the force of the bank (plays ``z`` at ``v0``) reaches zero on the way from
    ``v0`` (force of sign ``side``) to ``v1`` (opposite sign): bisection on the branch
    (piecewise linear and monotone), to round-off."""
    zt = z.copy()
    lo = v0
    hi = v1
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if mid == lo or mid == hi:
            break
        for i in range(r.shape[0]):
            zt[i] = max(mid - r[i], min(mid + r[i], z[i]))
        if _stop_force(mid, r, w, k, zt) * side > 0.0:
            lo = mid
        else:
            hi = mid
    return hi


@njit(cache=True, nogil=True)
def stop_gap_output(u, r, w, k, h, z, s, out, vout):  # pragma: no cover - compiled
    """Stop bank ``F(v) = k v + sum w_i (v - z_i)`` behind a backlash gap of half-width ``h > 0``.

    ``s = [v, x]``: the bank's input ``v`` and the gap position ``x = u - v`` (``|x| <= h``);
    ``vout`` receives ``v`` per sample.
    In contact (``|x| = h``) the bank follows ``v = u - sign(x) h`` as long as its force keeps
    the sign of the contact; where that force would cross zero the bank stops at the zero
    (:func:`_branch_zero`) and the gap opens: ``v`` holds, the force stays
    0, until the input has crossed the gap and touches its other (or the same) side.
    """
    N = u.shape[0]
    n = r.shape[0]
    v = s[0]
    x = s[1]
    z1 = z.copy()  # the plays moved to the contact's side: one buffer, not one a sample
    for t in range(N):
        ut = u[t]
        if abs(x) >= h:  # in contact
            side = 1.0 if x > 0 else (-1.0 if x < 0 else 0.0)
            vt = ut - side * h
            # z1 = the plays clipped at vt and ft = the force there (_clip_plays and
            # _stop_force on a copy, in one pass and the same order of operations)
            ft = k * vt
            for i in range(n):
                zi = max(vt - r[i], min(vt + r[i], z[i]))
                z1[i] = zi
                ft += w[i] * (vt - zi)
            if ft * side < 0.0:
                if _stop_force(v, r, w, k, z) * side > 0.0:
                    v = _branch_zero(v, vt, r, w, k, z, side)
                _clip_plays(v, r, z)
                x = ut - v
            else:  # stays in contact: the re-close below would give the same v, z, force
                v = vt
                for i in range(n):
                    z[i] = z1[i]
                x = side * h
                out[t] = ft
                vout[t] = v
                continue
        else:
            x = ut - v
        if abs(x) >= h:  # (re)closed on the side the input reached
            side = 1.0 if x > 0 else -1.0
            v = ut - side * h
            _clip_plays(v, r, z)
            x = side * h
        # open: no force passes the gap (exactly 0, not the zero search's round-off)
        out[t] = _stop_force(v, r, w, k, z) if abs(x) >= h else 0.0
        vout[t] = v
    s[0] = v
    s[1] = x


@njit(cache=True, nogil=True, fastmath={"reassoc"})
def pi_batch(u, R, W, p0, Z, out):  # pragma: no cover - compiled
    """Evaluate S parameter sets on one input (slider dragging, sweeps).

    Parameters
    ----------
    u : ndarray of shape (N,)
    R, W : ndarray of shape (S, n)
        Thresholds and weights per set.
    p0 : ndarray of shape (S,)
    Z : ndarray of shape (S, n)
        States, updated in place.
    out : ndarray of shape (S, N)
    """
    S = R.shape[0]
    N = u.shape[0]
    n = R.shape[1]
    for s in range(S):
        for k in range(N):
            uk = u[k]
            acc = 0.0
            for i in range(n):
                zi = Z[s, i]
                zi = min(zi, uk + R[s, i])
                zi = max(zi, uk - R[s, i])
                Z[s, i] = zi
                acc += W[s, i] * zi
            out[s, k] = p0[s] * uk + acc


@njit(cache=True, nogil=True)
def level_segments_rows(z, e, out):  # pragma: no cover - compiled
    """Level-segment functions of ``z`` ``(M,)`` at the increasing knots ``e`` ``(m - 1,)``,
    ``m >= 2``, into ``out`` ``(M, m)`` (row-major): ``min(z, e_0)``,
    ``clip(z, e_{j-1}, e_j) - e_{j-1}``, ``max(z, e_{m-2}) - e_{m-2}``; one pass over ``z``
    with the same comparisons and subtractions as the numpy form, so bit-identical to it
    (a NaN propagates to every segment)."""
    m = e.size + 1
    last = e[m - 2]
    for k in range(z.size):
        v = z[k]
        if v != v:
            for j in range(m):
                out[k, j] = v
            continue
        out[k, 0] = v if v < e[0] else e[0]
        for j in range(1, m - 1):
            lo = e[j - 1]
            hi = e[j]
            c = v if v > lo else lo
            c = c if c < hi else hi
            out[k, j] = c - lo
        out[k, m - 1] = (v if v > last else last) - last
    return out


@njit(cache=True, nogil=True)
def _level_sum(zi, e, W, i):  # pragma: no cover - compiled
    """``F_i(zi) = sum_j W[i, j] seg_j(zi)`` of one play output (see :mod:`core.preisach`)."""
    m = W.shape[1]
    if m == 1:
        return W[i, 0] * zi
    acc = W[i, 0] * min(zi, e[0])
    for j in range(1, m - 1):
        acc += W[i, j] * (min(max(zi, e[j - 1]), e[j]) - e[j - 1])
    acc += W[i, m - 1] * (max(zi, e[m - 2]) - e[m - 2])
    return acc


@njit(cache=True, nogil=True)
def _preisach_at(x, r, e, W, z):  # pragma: no cover - compiled
    """Preisach output for input ``x`` from play states ``z`` (``z`` is not changed)."""
    acc = 0.0
    for i in range(r.shape[0]):
        acc += _level_sum(play_update(z[i], x, r[i]), e, W, i)
    return acc


@njit(cache=True, nogil=True)
def preisach_output(u, r, e, W, z, out):  # pragma: no cover - compiled
    """Preisach output ``y = sum_i F_i(Γ_{r_i}[u])`` in the play form, summed sequentially.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input samples.
    r : ndarray of shape (n,)
        Thresholds, ``r >= 0``.
    e : ndarray of shape (m - 1,)
        Increasing level knots (input units); may be empty when ``m == 1``.
    W : ndarray of shape (n, m)
        Weight of play ``i`` on level segment ``j``.
    z : ndarray of shape (n,)
        Play outputs before the first sample; updated in place to the final state.
    out : ndarray of shape (N,)
    """
    n = r.shape[0]
    for k in range(u.shape[0]):
        uk = u[k]
        acc = 0.0
        for i in range(n):
            zi = play_update(z[i], uk, r[i])
            z[i] = zi
            acc += _level_sum(zi, e, W, i)
        out[k] = acc


@njit(cache=True, nogil=True)
def preisach_inverse(y, r, e, W, z, b, out):  # pragma: no cover - compiled
    """Exact per-sample inverse of :func:`preisach_output` (``W >= 0``, ``W[0] > 0``, r[0] = 0).

    Given the play states, the output is a continuous, strictly increasing, piecewise-linear
    function of the current input whose kinks lie among the points ``z_i ± r_i`` (a play
    starts to move) and ``e_j ± r_i`` (a moving play crosses a level knot). Those points are
    sorted into ``b``; a binary search on the output at them brackets ``y_k`` on one linear
    piece, where the input is solved for exactly; below the first (above the last) point the
    slope is ``sum_i W[i, 0]`` (``sum_i W[i, m-1]``). The plays then advance to that input.

    Parameters
    ----------
    y : ndarray of shape (N,)
        Desired outputs.
    r, e, W
        As in :func:`preisach_output`.
    z : ndarray of shape (n,)
        Play states, updated in place.
    b : ndarray of shape (2 n m,)
        Work buffer for the candidate kinks.
    out : ndarray of shape (N,)
        Inputs written.
    """
    n = r.shape[0]
    m = W.shape[1]
    s_lo = 0.0
    s_hi = 0.0
    for i in range(n):
        s_lo += W[i, 0]
        s_hi += W[i, m - 1]
    K = b.shape[0]
    for k in range(y.shape[0]):
        yk = y[k]
        q = 0
        for i in range(n):
            b[q] = z[i] - r[i]
            b[q + 1] = z[i] + r[i]
            q += 2
            for j in range(m - 1):
                b[q] = e[j] - r[i]
                b[q + 1] = e[j] + r[i]
                q += 2
        b.sort()
        f_first = _preisach_at(b[0], r, e, W, z)
        f_last = _preisach_at(b[K - 1], r, e, W, z)
        if yk < f_first:
            uk = b[0] + (yk - f_first) / s_lo
        elif yk >= f_last:
            uk = b[K - 1] + (yk - f_last) / s_hi
        else:
            lo = 0
            hi = K - 1
            f_lo = f_first
            f_hi = f_last
            while hi - lo > 1:
                mid = (lo + hi) // 2
                f_mid = _preisach_at(b[mid], r, e, W, z)
                if f_mid <= yk:
                    lo = mid
                    f_lo = f_mid
                else:
                    hi = mid
                    f_hi = f_mid
            uk = b[lo] + (yk - f_lo) * (b[hi] - b[lo]) / (f_hi - f_lo)
        for i in range(n):
            z[i] = play_update(z[i], uk, r[i])
        out[k] = uk


@njit(cache=True, nogil=True)
def _bw_rate(z, s, beta, gamma, n):  # pragma: no cover - compiled
    """``dz/du = 1 - (beta sign(du z) + gamma) |z|^n`` for an input moving in direction ``s``."""
    sz = s * z
    sg = 1.0 if sz > 0.0 else (-1.0 if sz < 0.0 else 0.0)
    a = abs(z)
    if n == 1.0:
        p = a
    elif n == 2.0:
        p = a * a
    else:
        p = a**n
    return 1.0 - (beta * sg + gamma) * p


@njit(cache=True, nogil=True)
def _clip(z, lim):  # pragma: no cover - compiled
    """``z`` limited to ``[-lim, lim]``."""
    if z > lim:
        return lim
    if z < -lim:
        return -lim
    return z


@njit(cache=True, nogil=True)
def _bw_move(du, beta, gamma, n, zlim, h, kmax, z):  # pragma: no cover - compiled
    """Advance every ``z_j`` (in place) over an input move ``du`` (see :func:`bouc_wen_bank`)."""
    if du == 0.0:
        return
    kd = math.ceil(abs(du) / h)
    if kd < 1.0:
        kd = 1.0
    if kmax > 0 and kd > kmax:
        kd = float(kmax)
    K = int(kd)
    dx = du / kd
    s = 1.0 if du > 0.0 else -1.0
    for j in range(z.shape[0]):
        zj = z[j]
        b = beta[j]
        g = gamma[j]
        e = n[j]
        lim = zlim[j]
        for _ in range(K):
            k1 = _bw_rate(zj, s, b, g, e)
            k2 = _bw_rate(_clip(zj + 0.5 * dx * k1, lim), s, b, g, e)
            k3 = _bw_rate(_clip(zj + 0.5 * dx * k2, lim), s, b, g, e)
            k4 = _bw_rate(_clip(zj + dx * k3, lim), s, b, g, e)
            zj += dx * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            if zj > lim:
                zj = lim
            elif zj < -lim:
                zj = -lim
        z[j] = zj


@njit(cache=True, nogil=True)
def bouc_wen_bank(u, x, beta, gamma, n, zlim, h, kmax, z, out):  # pragma: no cover - compiled
    """Hysteretic variables of a bank of rate-independent Bouc-Wen elements.

    Element ``j`` follows ``dz_j/du = 1 - (beta_j sign(du z_j) + gamma_j) |z_j|^n_j``, integrated
    in the input from the previous input value to each sample with ``K = ceil(|du| / h)``
    classical RK4 sub-steps of equal length (``K`` at most ``kmax`` when ``kmax > 0``), every
    element over the same sub-steps; the RK4 stages and the result of each sub-step are
    clipped to ``[-zlim_j, zlim_j]``, the interval the exact solution never leaves. Inside it
    ``dz/du >= 0`` (for ``beta >= 0``), so every stage moves ``z`` with the input and a
    sub-step longer than RK4's stability limit (a jump past ``kmax`` sub-steps) still ends
    between ``z`` and the saturation it moves to, instead of diverging; in the accurate
    regime the stages never reach the bounds and nothing is clipped.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input samples.
    x : float
        Input before the first sample (the integration starts there).
    beta, gamma, n : ndarray of shape (m,)
        Shape parameters of each element.
    zlim : ndarray of shape (m,)
        Bound of each ``|z_j|`` (``inf`` for none).
    h : float
        Largest sub-step, input units, ``> 0``.
    kmax : int
        Most sub-steps per sample (``<= 0``: no limit).
    z : ndarray of shape (m,)
        Hysteretic variables at input ``x``; updated in place to those after the last sample.
    out : ndarray of shape (N, m)
        Written with ``z`` after each sample.
    """
    m = z.shape[0]
    for k in range(u.shape[0]):
        _bw_move(u[k] - x, beta, gamma, n, zlim, h, kmax, z)
        for j in range(m):
            out[k, j] = z[j]
        x = u[k]


@njit(cache=True, nogil=True)
def bouc_wen_output(
    u, x, k0, c, beta, gamma, n, zlim, h, kmax, z, out
):  # pragma: no cover - compiled
    """Output ``k0 u + sum_j c_j z_j`` of a Bouc-Wen bank (:func:`bouc_wen_bank`), summed
    sequentially; ``z`` is updated in place to the state after the last sample."""
    m = z.shape[0]
    for k in range(u.shape[0]):
        _bw_move(u[k] - x, beta, gamma, n, zlim, h, kmax, z)
        acc = k0 * u[k]
        for j in range(m):
            acc += c[j] * z[j]
        out[k] = acc
        x = u[k]


@njit(cache=True, nogil=True, inline="always")
def _illinois(t, ft, a, b, fa, fb, ga, gb, side):  # pragma: no cover - compiled
    """One step of the Illinois (modified regula falsi) solve of an increasing function
    bracketed by ``[a, b]`` (``f(a) <= 0 < f(b)``): the new point ``t`` with ``f(t) = ft``
    replaces the end on its side, and the other end's weight ``ga``/``gb`` is halved when the
    same side is replaced twice in a row (``side``: -1 the low end, 1 the high end last).
    Returns ``(a, b, fa, fb, ga, gb, side)``."""
    if ft <= 0.0:
        if side == -1:
            gb *= 0.5
        return t, b, ft, fb, ft, gb, -1
    if side == 1:
        ga *= 0.5
    return a, t, fa, ft, ga, ft, 1


@njit(cache=True, nogil=True)
def _bw_at(v, x, k0, c, beta, gamma, n, zlim, h, kmax, z, zt):  # pragma: no cover - compiled
    """Output at input ``v`` reached from ``(x, z)``; the variables there go to ``zt``."""
    for j in range(z.shape[0]):
        zt[j] = z[j]
    _bw_move(v - x, beta, gamma, n, zlim, h, kmax, zt)
    acc = k0 * v
    for j in range(z.shape[0]):
        acc += c[j] * zt[j]
    return acc


@njit(cache=True, nogil=True)
def bouc_wen_inverse(  # noqa: C901 - a compiled kernel: one loop, calls out of it cost per sample
    y, x, k0, c, beta, gamma, n, zlim, h, kmax, mlo, mhi, z, zt, out
):  # pragma: no cover - compiled
    """Per-sample inverse of :func:`bouc_wen_output` (slopes in ``[mlo, mhi]``, ``mlo > 0``).

    From ``(x, z)`` the output is a continuous increasing function of the next input ``v``
    with slope between ``mlo`` and ``mhi``, so ``v`` lies in the bracket given by those
    slopes; it is found by regula falsi with the Illinois rule (at most 80 evaluations,
    stopping at adjacent doubles or an exact hit) and the variables advance to it.

    Parameters
    ----------
    y : ndarray of shape (N,)
        Desired outputs.
    x : float
        Input before the first sample.
    k0, c, beta, gamma, n, zlim, h, kmax
        As in :func:`bouc_wen_output`.
    mlo, mhi : float
        Smallest and largest slope ``dy/du``.
    z : ndarray of shape (m,)
        Variables, updated in place.
    zt : ndarray of shape (m,)
        Work buffer.
    out : ndarray of shape (N,)
        Inputs written.

    Returns
    -------
    float
        The input after the last sample.
    """
    m = z.shape[0]
    for k in range(y.shape[0]):
        yk = y[k]
        f0 = k0 * x
        for j in range(m):
            f0 += c[j] * z[j]
        d = yk - f0
        if d == 0.0:
            v = x
        else:
            if d > 0.0:
                a = x + d / mhi
                b = x + d / mlo
            else:
                a = x + d / mlo
                b = x + d / mhi
            fa = _bw_at(a, x, k0, c, beta, gamma, n, zlim, h, kmax, z, zt) - yk
            fb = _bw_at(b, x, k0, c, beta, gamma, n, zlim, h, kmax, z, zt) - yk
            w0 = b - a
            if w0 <= 0.0:  # a move below the input's round-off: widen from |d| / mlo
                w0 = abs(d) / mlo
            w = w0
            for _ in range(60):  # round-off at the bracket's ends: widen it
                if fa <= 0.0:
                    break
                a -= w
                w *= 2.0
                fa = _bw_at(a, x, k0, c, beta, gamma, n, zlim, h, kmax, z, zt) - yk
            w = w0
            for _ in range(60):
                if fb >= 0.0:
                    break
                b += w
                w *= 2.0
                fb = _bw_at(b, x, k0, c, beta, gamma, n, zlim, h, kmax, z, zt) - yk
            ga = fa
            gb = fb
            side = 0
            for _ in range(80):
                if ga == 0.0 or gb == 0.0 or ga == gb:
                    break
                t = (a * gb - b * ga) / (gb - ga)
                if not (t > a and t < b):
                    t = 0.5 * (a + b)
                    if not (t > a and t < b):
                        break
                ft = _bw_at(t, x, k0, c, beta, gamma, n, zlim, h, kmax, z, zt) - yk
                a, b, fa, fb, ga, gb, side = _illinois(t, ft, a, b, fa, fb, ga, gb, side)
            v = a if -fa <= fb else b
        _bw_move(v - x, beta, gamma, n, zlim, h, kmax, z)
        out[k] = v
        x = v
    return x


# ---------------------------------------------------------------------------------------
# Menegotto-Pinto smooth stop elements (model in core.nonmasing)
#
# State vector (length 3 + 5 n): the last input, the branch direction (+1, -1; 0 before the
# first move from the virgin state), the input at the last reversal, then per element the
# element output s_i, its value at the last reversal s_r,i, the largest and the smallest
# input reached at a reversal so far (+r_i and -r_i before any excursion) and the branch's
# curvature R_i.


@njit(cache=True, nogil=True, inline="always")
def mp_unit(x, rr):  # pragma: no cover - compiled
    """``x / (1 + |x|^R)^(1/R)``, written so that a large ``R`` neither overflows nor
    underflows (``|x| > 1`` through ``|x|^-R``)."""
    ax = abs(x)
    if ax <= 1.0:
        return x / (1.0 + ax**rr) ** (1.0 / rr)
    v = 1.0 / (1.0 + ax ** (-rr)) ** (1.0 / rr)
    return v if x > 0.0 else -v


@njit(cache=True, nogil=True)
def mp_advance(v, r, r0, c1, c2, st):  # pragma: no cover - compiled
    """Move the elements' state ``st`` (layout above) to the input ``v``: a reversal where
    the input's direction changes starts a new branch of each element from its present
    output, with the curvature of its previous excursion; then each element's output on
    its branch at ``v``."""
    n = r.shape[0]
    u = st[0]
    d = st[1]
    du = v - u
    nd = 1.0 if du > 0.0 else (-1.0 if du < 0.0 else 0.0)
    if nd != 0.0 and nd != d:
        for i in range(n):
            b = 3 + 5 * i
            if d > 0.0:
                if u > st[b + 2]:
                    st[b + 2] = u
            elif d < 0.0:
                if u < st[b + 3]:
                    st[b + 3] = u
            sr = st[b]
            st[b + 1] = sr
            ua = u + nd * r[i] - sr  # where the unit line from the reversal meets nd r_i
            um = st[b + 2] if nd > 0.0 else st[b + 3]
            xi = abs(um - ua) / r[i]
            st[b + 4] = r0[i] * (1.0 - c1[i] * xi / (c2[i] + xi))
        st[1] = nd
        st[2] = u
        d = nd
    st[0] = v
    if d != 0.0:
        ur = st[2]
        for i in range(n):
            b = 3 + 5 * i
            sr = st[b + 1]
            span = d * r[i] - sr
            if span != 0.0:
                st[b] = sr + span * mp_unit((v - ur) / span, st[b + 4])


@njit(cache=True, nogil=True)
def mp_output(u, r, w, k, r0, c1, c2, st, out):  # pragma: no cover - compiled
    """``y = k u + sum_i w_i s_i[u]`` of a bank of Menegotto-Pinto elements; ``st``
    (layout above) is updated in place."""
    n = r.shape[0]
    for t in range(u.shape[0]):
        mp_advance(u[t], r, r0, c1, c2, st)
        y = k * u[t]
        for i in range(n):
            y += w[i] * st[3 + 5 * i]
        out[t] = y


@njit(cache=True, nogil=True)
def mp_elements(u, r, r0, c1, c2, st, out):  # pragma: no cover - compiled
    """Each element's output ``s_i[u_t]`` into ``out`` (shape ``(N, n)``), as
    :func:`mp_output` runs the elements; ``st`` (layout above) is updated in place."""
    n = r.shape[0]
    for t in range(u.shape[0]):
        mp_advance(u[t], r, r0, c1, c2, st)
        for i in range(n):
            out[t, i] = st[3 + 5 * i]


@njit(cache=True, nogil=True)
def _mp_at(v, r, w, k, r0, c1, c2, st, work):  # pragma: no cover - compiled
    """Output at the input ``v`` from the state ``st`` (left unchanged; ``work`` is
    overwritten)."""
    for j in range(st.shape[0]):
        work[j] = st[j]
    mp_advance(v, r, r0, c1, c2, work)
    y = k * v
    for i in range(r.shape[0]):
        y += w[i] * work[3 + 5 * i]
    return y


@njit(cache=True, nogil=True)
def mp_inverse(  # noqa: C901 - a compiled kernel: one loop, calls out of it cost per sample
    y, r, w, k, r0, c1, c2, mlo, mhi, st, work, out
):  # pragma: no cover - compiled
    """Per-sample inverse of :func:`mp_output` (branch slopes in ``[mlo, mhi]``,
    ``mlo > 0``): from the state the output is a continuous increasing function of the next
    input, so the input is bracketed from the slopes and found by regula falsi (Illinois)
    safeguarded by bisection, to adjacent doubles; then the state advances to it. Of the
    final bracket the end short of the target is taken, and never an input on the other side
    of the last one from the target (round-off): a reversal starts new branches, so a held
    target must not make one (it did by 1e-16, changing later outputs by up to 5 % of
    range)."""
    n = r.shape[0]
    for t in range(y.shape[0]):
        yt = y[t]
        x = st[0]
        f0 = k * x
        for i in range(n):
            f0 += w[i] * st[3 + 5 * i]
        dd = yt - f0
        v = x
        if dd != 0.0:
            if dd > 0.0:
                a = x + dd / mhi
                b = x + dd / mlo
            else:
                a = x + dd / mlo
                b = x + dd / mhi
            fa = _mp_at(a, r, w, k, r0, c1, c2, st, work) - yt
            fb = _mp_at(b, r, w, k, r0, c1, c2, st, work) - yt
            w0 = abs(dd) / mlo
            ww = w0
            for _ in range(60):  # round-off at the bracket's ends: widen it
                if fa <= 0.0:
                    break
                a -= ww
                ww *= 2.0
                fa = _mp_at(a, r, w, k, r0, c1, c2, st, work) - yt
            ww = w0
            for _ in range(60):
                if fb >= 0.0:
                    break
                b += ww
                ww *= 2.0
                fb = _mp_at(b, r, w, k, r0, c1, c2, st, work) - yt
            ga = fa
            gb = fb
            side = 0
            for it in range(200):
                if ga == 0.0 or gb == 0.0:
                    break
                if it % 4 == 3 or ga == gb:
                    tt = 0.5 * (a + b)  # a bisection every fourth step: a sure shrink
                else:
                    tt = (a * gb - b * ga) / (gb - ga)
                if not (tt > a and tt < b):
                    tt = 0.5 * (a + b)
                    if not (tt > a and tt < b):
                        break
                ft = _mp_at(tt, r, w, k, r0, c1, c2, st, work) - yt
                a, b, fa, fb, ga, gb, side = _illinois(tt, ft, a, b, fa, fb, ga, gb, side)
            if fa == 0.0:
                v = a
            elif fb == 0.0:
                v = b
            else:  # the end short of the target: a repeated target moves on, never back
                v = a if dd > 0.0 else b
            if (v - x) * dd < 0.0:  # round-off against the target's side: stay
                v = x
        mp_advance(v, r, r0, c1, c2, st)
        out[t] = v
