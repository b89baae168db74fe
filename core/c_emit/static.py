"""C emitters of the static stages of :mod:`core.stages`: offset, drift and the asymmetric
output map with its inverse."""

from __future__ import annotations

import numpy as np

from ..stages import (
    Asymmetry,
    AsymmetryInverse,
    Drift,
    Offset,
    SignedGain,
    bisect_steps,
)
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


@register_c_stage(Offset)
def _emit_offset(model: Offset, ctx: StageContext) -> CStage:
    """Constant output offset ``x <- x + c``."""
    c = float(model.offset)
    return CStage(
        title="output offset",
        constants=[f"static const double {ctx.const}C = {c_double(c)};"],
        step=[f"x = x + {ctx.const}C;"],
        tune=[f"{ctx.const}C = $offset[0];"],
    )


@register_c_stage(SignedGain)
def _emit_signed_gain(model: SignedGain, ctx: StageContext) -> CStage:
    """Gain by the input's sign ``x <- (x >= 0 ? g+ : g-) x``."""
    c = ctx.const
    return CStage(
        title="gain by the sign of the input",
        constants=[f"static const double {c}GP = {c_double(model.positive)};",
                   f"static const double {c}GN = {c_double(model.negative)};"],
        step=[f"x = (x >= 0.0) ? {c}GP * x : {c}GN * x;"],
        tune=[f"{c}GP = $positive[0];", f"{c}GN = $negative[0];"],
    )


@register_c_stage(Drift)
def _emit_drift(model: Drift, ctx: StageContext) -> CStage:
    """Legendre drift in time ``x + sum a_k P_k(clamp(2 t / T - 1))``, ``t = start + k dt``."""
    assert ctx.dt is not None
    a = np.asarray(model.coefficients)
    n, f, c = a.size, ctx.field, ctx.const
    return CStage(
        title=f"drift, Legendre degree {n}",
        fields=[f"double {f}k;"],
        constants=[
            f"static const double {c}A[{n}] = {c_array(a)};",
            f"static const double {c}T = {c_double(model.span_s)};",
            f"static const double {c}T0 = {c_double(model.start_s)};",
            f"static const double {c}DT = {c_double(ctx.dt)};",
        ],
        reset=[f"st->{f}k = 0.0;"],
        step=[
            f"{{ double s = 2.0 * ({c}T0 + st->{f}k * {c}DT) / {c}T - 1.0;",
            "  double p0 = 1.0, p1, acc = 0.0;",
            "  if (s > 1.0) s = 1.0;",
            "  if (s < -1.0) s = -1.0;",
            "  p1 = s;",
            f"  for (i = 0; i < {n}u; ++i) {{",
            f"      acc += {c}A[i] * p1;",
            "      { const double p2 = ((2.0 * (i + 1) + 1.0) * s * p1 - (i + 1) * p0) / (i + 2);",
            "        p0 = p1; p1 = p2; }",
            "  }",
            f"  st->{f}k += 1.0;",
            "  x = x + acc; }",
        ],
        tune=[f"for (i = 0; i < {n}u; ++i) {c}A[i] = $coefficients[i];",
              f"{c}T = $span_s[0];", f"{c}T0 = $start_s[0];"],
    )


def _asym_consts(model: Asymmetry | AsymmetryInverse, c: str) -> list[str]:
    a = np.asarray(model.coefficients)
    return [
        f"static const double {c}A[{a.size}] = {c_array(a)};",
        f"static const double {c}CTR = {c_double(model.center)};",
        f"static const double {c}S = {c_double(model.scale)};",
    ]


def _asym_helper(model: Asymmetry | AsymmetryInverse, c: str) -> list[str]:
    n = np.asarray(model.coefficients).size
    return [
        f"static double {c}map(double x)",
        "{",
        f"    const double q = (x - {c}CTR) / {c}S;",
        "    double acc = 0.0;",
        "    int k;",
        f"    for (k = {n - 1}; k >= 0; --k) acc = (acc + {c}A[k]) * q;",
        "    return x + acc * q;",
        "}",
    ]


@register_c_stage(Asymmetry)
def _emit_asymmetry(model: Asymmetry, ctx: StageContext) -> CStage:
    """Polynomial output map ``x + sum a_k ((x - c)/s)^k`` (Horner form)."""
    c = ctx.const
    n = np.asarray(model.coefficients).size
    return CStage(title="asymmetry output map", constants=_asym_consts(model, c),
                  helpers=_asym_helper(model, c), step=[f"x = {c}map(x);"],
                  tune=[f"for (i = 0; i < {n}u; ++i) {c}A[i] = $coefficients[i];",
                        f"{c}CTR = $center[0];", f"{c}S = $scale[0];"])


@register_c_stage(AsymmetryInverse)
def _emit_asymmetry_inverse(model: AsymmetryInverse, ctx: StageContext) -> CStage:
    """Inverse output map: clip to the monotone range, bracket, 80 bisection steps.

    ``LOF``/``HIF`` say whether the range ends ``LO``/``HI`` are finite (else the bracket
    grows by doubling), so the same code serves a range retuned in the FMU."""

    lo, hi = model.forward.monotone_range()
    f, c = ctx.field, ctx.const
    n = np.asarray(model.coefficients).size
    step = [
        "{ double lo, hi; int j, done = 0;",
        f"  if ({c}LOF != 0.0 && x < {c}map({c}LO)) {{ x = {c}LO; ++st->{f}clipped; done = 1; }}",
        f"  if (!done && {c}HIF != 0.0 && x > {c}map({c}HI)) {{",
        f"      x = {c}HI; ++st->{f}clipped; done = 1;",
        "  }",
        f"  lo = {c}LOF != 0.0 ? {c}LO : {c}CTR - {c}S;",
        f"  hi = {c}HIF != 0.0 ? {c}HI : {c}CTR + {c}S;",
        "  for (j = 0; j < 64; ++j) {",
        f"      if ({c}LOF == 0.0 && {c}map(lo) > x) lo = {c}CTR - 2.0 * ({c}CTR - lo);",
        f"      if ({c}HIF == 0.0 && {c}map(hi) < x) hi = {c}CTR + 2.0 * (hi - {c}CTR);",
        "  }",
        "  if (!done) {",
        f"    for (j = 0; j < {bisect_steps()}; ++j) {{",
        "        const double mid = 0.5 * (lo + hi);",
        f"        if ({c}map(mid) < x) lo = mid; else hi = mid;",
        "    }",
        "    x = 0.5 * (lo + hi);",
        "  } }",
    ]
    fin_lo, fin_hi = bool(np.isfinite(lo)), bool(np.isfinite(hi))
    consts = _asym_consts(model, c) + [
        f"static const double {c}LO = {c_double(lo if fin_lo else 0.0)};",
        f"static const double {c}HI = {c_double(hi if fin_hi else 0.0)};",
        f"static const double {c}LOF = {c_double(float(fin_lo))};",
        f"static const double {c}HIF = {c_double(float(fin_hi))};",
    ]
    return CStage(
        title="inverse asymmetry map (clips to its range, counts clipped samples)",
        fields=[f"unsigned long {f}clipped;"], constants=consts,
        helpers=_asym_helper(model, c), reset=[f"st->{f}clipped = 0ul;"], step=step,
        tune=[f"for (i = 0; i < {n}u; ++i) {c}A[i] = $coefficients[i];",
              f"{c}CTR = $center[0]; {c}S = $scale[0];",
              f"{c}range({c}A, {c}S, &{c}LOF, &{c}LO, &{c}HIF, &{c}HI);",
              f"{c}LO = {c}CTR + {c}S * {c}LO; {c}HI = {c}CTR + {c}S * {c}HI;"],
        tune_helpers=_monotone_range_helper(n, c),
    )


def _monotone_range_helper(n: int, c: str) -> list[str]:
    """C of ``{c}range(a, s, &lof, &lo, &hif, &hi)``: as ``Asymmetry.monotone_range`` (in
    ``q`` units), the real roots of ``s + sum_k k a_k q^(k-1)`` nearest 0 on each side, the
    roots found by Durand-Kerner iteration (``np.roots``' tolerance on the imaginary part)."""
    d = n  # degree of the derivative polynomial before trimming leading zeros
    return [
        f"/* monotone range of the asymmetry map: derivative roots (degree <= {d}) */",
        f"static void {c}range(const double *a, double s, double *lof, double *lo,",
        "                     double *hif, double *hi)",
        "{",
        f"    double p[{d + 1}], zr[{d}], zi[{d}];",
        "    unsigned i, j, it, m, first = 0u;",
        f"    for (i = 0; i < {d}u; ++i) p[i] = (double)({d + 1}u - i) * a[{d - 1}u - i];",
        f"    p[{d}] = s;",
        f"    while (first < {d}u && p[first] == 0.0) ++first;",
        f"    m = {d}u - first; /* degree */",
        "    for (i = 0; i < m; ++i) { /* initial guesses (0.4 + 0.9i)^(i+1) */",
        "        double r = 0.4, im = 0.9;",
        "        for (j = 0; j < i; ++j) {",
        "            const double t = r * 0.4 - im * 0.9;",
        "            im = r * 0.9 + im * 0.4;",
        "            r = t;",
        "        }",
        "        zr[i] = r; zi[i] = im;",
        "    }",
        "    for (it = 0; it < 2000u; ++it) {",
        "        double change = 0.0;",
        "        for (i = 0; i < m; ++i) {",
        "            double vr = 1.0, vi = 0.0, dr = 1.0, di = 0.0, nr, ni, den;",
        "            for (j = 1; j <= m; ++j) { /* monic polynomial value (Horner) */",
        "                const double t = vr * zr[i] - vi * zi[i] + p[first + j] / p[first];",
        "                vi = vr * zi[i] + vi * zr[i];",
        "                vr = t;",
        "            }",
        "            for (j = 0; j < m; ++j) { /* prod over the other roots */",
        "                double t;",
        "                if (j == i) continue;",
        "                t = dr * (zr[i] - zr[j]) - di * (zi[i] - zi[j]);",
        "                di = dr * (zi[i] - zi[j]) + di * (zr[i] - zr[j]);",
        "                dr = t;",
        "            }",
        "            den = dr * dr + di * di;",
        "            if (den == 0.0) { zr[i] += 1e-8; continue; }",
        "            nr = (vr * dr + vi * di) / den;",
        "            ni = (vi * dr - vr * di) / den;",
        "            zr[i] -= nr; zi[i] -= ni;",
        "            if (fabs(nr) + fabs(ni) > change) change = fabs(nr) + fabs(ni);",
        "        }",
        "        if (change == 0.0) break;",
        "    }",
        "    *lof = 0.0; *hif = 0.0; *lo = 0.0; *hi = 0.0;",
        "    for (i = 0; i < m; ++i) {",
        "        const double mag = sqrt(zr[i] * zr[i] + zi[i] * zi[i]);",
        "        if (fabs(zi[i]) > 1e-12 * (mag > 1.0 ? mag : 1.0)) continue;",
        "        if (zr[i] < 0.0 && (*lof == 0.0 || zr[i] > *lo)) { *lo = zr[i]; *lof = 1.0; }",
        "        if (zr[i] > 0.0 && (*hif == 0.0 || zr[i] < *hi)) { *hi = zr[i]; *hif = 1.0; }",
        "    }",
        "}",
    ]
