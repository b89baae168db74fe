"""C emitters of the Preisach models (:mod:`core.preisach`): the levelled plays, their
inverse, and the rate-dependent form."""

from __future__ import annotations

import numpy as np

from ..preisach import (
    PreisachInverse,
    PreisachModel,
    RateDependentPreisach,
    RateDependentPreisachInverse,
)
from ..validation import filled
from .rate import rate_bisection_step
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


def _preisach_parts(model: PreisachModel | RateDependentPreisach, ctx: StageContext,
                    rate: bool = False) -> tuple[list[str], list[str], list[str]]:
    """Constants, reset and helpers (``level``, ``eval``) of a Preisach play bank; with
    ``rate`` (a :class:`RateDependentPreisach`), ``eval(x, zin, up, has_prev, zout)`` with
    the thresholds ``r_i + K |x - up|`` of the plays with ``r_i > 0``."""
    n, m = model.n, model.n_segments
    f, c = ctx.field, ctx.const
    consts = [
        f"static const double {c}R[{n}] = {c_array(model.thresholds)};",
        f"static const double {c}W[{n * m}] = {c_array(model.weights)};",
        f"static const double {c}Z0[{n}] = {c_array(filled(model.state0))};",
    ]
    level = [
        "/* contribution W[i][:] . seg(z) of play i at output z (level segments) */",
        f"static double {c}level(double z, unsigned i)",
        "{",
        f"    const double *w = {c}W + i * {m}u;",
    ]
    if m == 1:
        level += ["    return w[0] * z;", "}"]
    else:
        consts.append(f"static const double {c}E[{m - 1}] = {c_array(model.knots)};")
        level.append(f"    double acc = w[0] * (z < {c}E[0] ? z : {c}E[0]);")
        if m > 2:
            level += [
                "    unsigned j;",
                f"    for (j = 1; j < {m - 1}u; ++j) {{",
                f"        double s = z > {c}E[j - 1] ? z : {c}E[j - 1];",
                f"        if (s > {c}E[j]) s = {c}E[j];",
                f"        acc += w[j] * (s - {c}E[j - 1]);",
                "    }",
            ]
        level += [
            f"    acc += w[{m - 1}] * ((z > {c}E[{m - 2}] ? z : {c}E[{m - 2}]) - {c}E[{m - 2}]);",
            "    return acc;",
            "}",
        ]
    if not rate:
        helpers = level + [
            "/* output at input x from the plays zin; the new plays go to zout (if any) */",
            f"static double {c}eval(double x, const double *zin, double *zout)",
            "{",
            "    unsigned i;",
            "    double acc = 0.0;",
            f"    for (i = 0; i < {n}u; ++i) {{",
            "        double zi = zin[i];",
            f"        if (zi > x + {c}R[i]) zi = x + {c}R[i];",
            f"        if (zi < x - {c}R[i]) zi = x - {c}R[i];",
            "        if (zout) zout[i] = zi;",
            f"        acc += {c}level(zi, i);",
            "    }",
            "    return acc;",
            "}",
        ]
        return consts, [f"for (i = 0; i < {n}u; ++i) st->{f}z[i] = {c}Z0[i];"], helpers
    assert ctx.dt is not None and isinstance(model, RateDependentPreisach)
    consts.append(f"static const double {c}K = {c_double(model.beta_s / ctx.dt)};")
    helpers = level + [
        "/* output at input x from the plays zin (previous input up), thresholds widened",
        "   by K |x - up| except the reversible r = 0; the new plays go to zout (if any) */",
        f"static double {c}eval(double x, const double *zin, double up, int has_prev,",
        "                    double *zout)",
        "{",
        "    unsigned i;",
        f"    const double extra = has_prev ? {c}K * fabs(x - up) : 0.0;",
        "    double acc = 0.0;",
        f"    for (i = 0; i < {n}u; ++i) {{",
        "        double zi = zin[i];",
        f"        const double ri = {c}R[i] == 0.0 ? 0.0 : {c}R[i] + extra;",
        "        if (zi > x + ri) zi = x + ri;",
        "        if (zi < x - ri) zi = x - ri;",
        "        if (zout) zout[i] = zi;",
        f"        acc += {c}level(zi, i);",
        "    }",
        "    return acc;",
        "}",
    ]
    reset = [f"st->{f}has_prev = 0;", f"st->{f}up = 0.0;",
             f"for (i = 0; i < {n}u; ++i) st->{f}z[i] = {c}Z0[i];"]
    return consts, reset, helpers


def _preisach_tune(model: PreisachModel | RateDependentPreisach, c: str, pre: str) -> list[str]:
    """Tune lines of a Preisach bank whose fields are ``$<pre>thresholds`` etc."""
    n, m = model.n, model.n_segments
    return [
        f"for (i = 0; i < {n}u; ++i) {{",
        f"    {c}R[i] = ${pre}thresholds[i]; {c}Z0[i] = ${pre}state0[i];",
        "}",
        f"for (i = 0; i < {n * m}u; ++i) {c}W[i] = ${pre}weights[i];",
        *([f"for (i = 0; i < {m - 1}u; ++i) {c}E[i] = ${pre}knots[i];"] if m > 1 else []),
    ]


@register_c_stage(PreisachModel)
def _emit_preisach(model: PreisachModel, ctx: StageContext) -> CStage:
    """Preisach play bank ``x <- sum_i sum_j W[i][j] seg_j(z_i)`` (as ``preisach_output``)."""
    n, m = model.n, model.n_segments
    f, c = ctx.field, ctx.const
    consts, reset, helpers = _preisach_parts(model, ctx)
    return CStage(
        title=f"Preisach model, {n} play operator(s) x {m} level segment(s)",
        fields=[f"double {f}z[{n}];"], constants=consts, reset=reset, helpers=helpers,
        step=[f"x = {c}eval(x, st->{f}z, st->{f}z);"],
        tune=_preisach_tune(model, c, ""),
    )


@register_c_stage(PreisachInverse)
def _emit_preisach_inverse(model: PreisachInverse, ctx: StageContext) -> CStage:
    """Exact per-sample inverse of the Preisach model (as ``core.kernels.preisach_inverse``)."""
    fwd = model.model
    n, m = fwd.n, fwd.n_segments
    f, c = ctx.field, ctx.const
    k = 2 * n * m
    consts, reset, helpers = _preisach_parts(fwd, ctx)
    w = np.asarray(fwd.weights)
    consts += [f"static const double {c}SLO = {c_double(float(np.sum(w[:, 0])))};",
               f"static const double {c}SHI = {c_double(float(np.sum(w[:, -1])))};"]
    knots = [
        f"        for (j = 0; j < {m - 1}u; ++j) {{",
        f"            b[q++] = {c}E[j] - {c}R[i];",
        f"            b[q++] = {c}E[j] + {c}R[i];",
        "        }",
    ] if m > 1 else []
    helpers += [
        "/* the input whose output from the plays z is y (exact, on its linear piece);"
        " advances z */",
        f"static double {c}solve(double y, double *z)",
        "{",
        f"    double b[{k}];",
        "    double f0, f1, uk;",
        "    unsigned i, q = 0u;",
        *(["    unsigned j;"] if m > 1 else []),
        f"    for (i = 0; i < {n}u; ++i) {{",
        f"        b[q++] = z[i] - {c}R[i];",
        f"        b[q++] = z[i] + {c}R[i];",
        *knots,
        "    }",
        f"    for (i = 1; i < {k}u; ++i) {{ /* insertion sort of the candidate kinks */",
        "        const double v = b[i];",
        "        q = i;",
        "        while (q > 0u && b[q - 1] > v) { b[q] = b[q - 1]; --q; }",
        "        b[q] = v;",
        "    }",
        f"    f0 = {c}eval(b[0], z, 0);",
        f"    f1 = {c}eval(b[{k - 1}], z, 0);",
        "    if (y < f0) {",
        f"        uk = b[0] + (y - f0) / {c}SLO;",
        "    } else if (y >= f1) {",
        f"        uk = b[{k - 1}] + (y - f1) / {c}SHI;",
        "    } else {",
        f"        unsigned lo = 0u, hi = {k - 1}u;",
        "        while (hi - lo > 1u) {",
        "            const unsigned mid = (lo + hi) / 2u;",
        f"            const double fm = {c}eval(b[mid], z, 0);",
        "            if (fm <= y) { lo = mid; f0 = fm; } else { hi = mid; f1 = fm; }",
        "        }",
        "        uk = b[lo] + (y - f0) * (b[hi] - b[lo]) / (f1 - f0);",
        "    }",
        f"    (void){c}eval(uk, z, z);",
        "    return uk;",
        "}",
    ]
    return CStage(
        title=f"inverse Preisach model, {n} play operator(s) x {m} level segment(s), exact",
        fields=[f"double {f}z[{n}];"], constants=consts, reset=reset, helpers=helpers,
        step=[f"x = {c}solve(x, st->{f}z);"],
        tune=[*_preisach_tune(fwd, c, "model."),
              f"{c}SLO = 0.0; {c}SHI = 0.0;",
              f"for (i = 0; i < {n}u; ++i) {{",
              f"    {c}SLO += {c}W[i * {m}u]; {c}SHI += {c}W[i * {m}u + {m - 1}u];",
              "}"],
    )


def _rate_preisach_slopes(n: int, m: int, c: str) -> list[str]:
    """Tune lines recomputing the slope bounds ``MLO``/``MHI`` of a rate-dependent Preisach
    bank (as :meth:`RateDependentPreisach.slope_bounds`)."""
    return ["{ double lo = 0.0, hi = 0.0;",
            f"  for (i = 0; i < {n}u; ++i) {{",
            f"      double mn = {c}W[i * {m}u], mx = mn;",
            f"      for (j = 1; j < {m}u; ++j) {{",
            f"          if ({c}W[i * {m}u + j] < mn) mn = {c}W[i * {m}u + j];",
            f"          if ({c}W[i * {m}u + j] > mx) mx = {c}W[i * {m}u + j];",
            "      }",
            f"      if ({c}R[i] == 0.0) {{ lo += mn; hi += mx; }}",
            f"      else {{ if ((1.0 - {c}K) * mx < 0.0) lo += (1.0 - {c}K) * mx;"
            f" hi += (1.0 + {c}K) * mx; }}",
            "  }",
            f"  {c}MLO = lo; {c}MHI = hi; }}"]


@register_c_stage(RateDependentPreisach)
def _emit_rate_preisach(model: RateDependentPreisach, ctx: StageContext) -> CStage:
    """Rate-dependent Preisach bank (as ``RateDependentPreisach``)."""
    assert ctx.dt is not None
    n, m = model.n, model.n_segments
    f, c = ctx.field, ctx.const
    consts, reset, helpers = _preisach_parts(model, ctx, rate=True)
    return CStage(
        title=f"rate-dependent Preisach model, {n} play operator(s) x {m} level segment(s)",
        fields=[f"double {f}z[{n}];", f"double {f}up;", f"int {f}has_prev;"],
        constants=consts, reset=reset, helpers=helpers,
        step=["{ const double xin = x;",
              f"  x = {c}eval(xin, st->{f}z, st->{f}up, st->{f}has_prev, st->{f}z);",
              f"  st->{f}up = xin;",
              f"  st->{f}has_prev = 1; }}"],
        tune=[*_preisach_tune(model, c, ""), f"{c}K = $beta_s[0] / {c_double(ctx.dt)};"],
        needs_math=True,
    )


@register_c_stage(RateDependentPreisachInverse)
def _emit_rate_preisach_inverse(model: RateDependentPreisachInverse, ctx: StageContext) -> CStage:
    """Per-sample bisection of the rate-dependent Preisach (as
    ``RateDependentPreisachInverse``)."""
    assert ctx.dt is not None
    m_lo, m_hi = model.checked_slopes(ctx.dt)
    fwd = model.model
    n, m = fwd.n, fwd.n_segments
    f, c = ctx.field, ctx.const
    consts, reset, helpers = _preisach_parts(fwd, ctx, rate=True)
    consts += [f"static const double {c}MLO = {c_double(m_lo)};",
               f"static const double {c}MHI = {c_double(m_hi)};"]
    return CStage(
        title=f"inverse rate-dependent Preisach model, {n} play operator(s) x {m} level "
        "segment(s), per-sample bisection",
        fields=[f"double {f}z[{n}];", f"double {f}up;", f"int {f}has_prev;"],
        constants=consts, reset=reset, helpers=helpers,
        tune=[*_preisach_tune(fwd, c, "model."),
              f"{c}K = $model.beta_s[0] / {c_double(ctx.dt)};",
              *_rate_preisach_slopes(n, m, c)],
        step=rate_bisection_step(f, c),
        needs_math=True,
    )
