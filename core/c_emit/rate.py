"""C emitters of the rate-dependent PI model and its inverse
(:class:`core.stages.RateDependentPI`)."""

from __future__ import annotations

from ..stages import (
    RateDependentPI,
    RateDependentPIInverse,
)
from ..validation import filled
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


def _rate_parts(model: RateDependentPI | RateDependentPIInverse, ctx: StageContext
                ) -> tuple[list[str], list[str], list[str]]:
    """Constants, reset and the helper ``eval(x, st)`` of a rate-dependent PI stage."""
    assert ctx.dt is not None
    n, f, c = model.thresholds.size, ctx.field, ctx.const
    consts = [
        f"static const double {c}P0 = {c_double(model.p0)};",
        f"static const double {c}R[{n}] = {c_array(model.thresholds)};",
        f"static const double {c}W[{n}] = {c_array(model.weights)};",
        f"static const double {c}Z0[{n}] = {c_array(filled(model.state0))};",
        f"static const double {c}K = {c_double(model.beta_s / ctx.dt)};",
    ]
    reset = [f"st->{f}has_prev = 0;", f"st->{f}up = 0.0;",
             f"for (i = 0; i < {n}u; ++i) st->{f}z[i] = {c}Z0[i];"]
    helper = [
        "/* rate-dependent play bank at input x: output, and the new plays into z (if any) */",
        f"static double {c}eval(double x, const double *zin, double up, int has_prev, double *z)",
        "{",
        "    unsigned i;",
        f"    const double extra = has_prev ? {c}K * fabs(x - up) : 0.0;",
        f"    double acc = {c}P0 * x;",
        f"    for (i = 0; i < {n}u; ++i) {{",
        f"        const double ri = {c}R[i] + extra;",
        "        double zi = zin[i];",
        "        if (zi > x + ri) zi = x + ri;",
        "        if (zi < x - ri) zi = x - ri;",
        "        if (z) z[i] = zi;",
        f"        acc += {c}W[i] * zi;",
        "    }",
        "    return acc;",
        "}",
    ]
    return consts, reset, helper


def _rate_tune(n: int, c: str, dt: float) -> list[str]:
    return [f"{c}P0 = $p0[0];",
            f"for (i = 0; i < {n}u; ++i) {{",
            f"    {c}R[i] = $thresholds[i]; {c}W[i] = $weights[i]; {c}Z0[i] = $state0[i];",
            "}",
            f"{c}K = $beta_s[0] / {c_double(dt)};"]


@register_c_stage(RateDependentPI)
def _emit_rate(model: RateDependentPI, ctx: StageContext) -> CStage:
    """Rate-dependent PI: thresholds ``r_i + beta |x_k - x_(k-1)| / dt``."""
    assert ctx.dt is not None
    f, c = ctx.field, ctx.const
    n = model.thresholds.size
    consts, reset, helper = _rate_parts(model, ctx)
    return CStage(
        title=f"rate-dependent PI, {n} play operator(s)",
        fields=[f"double {f}z[{n}];", f"double {f}up;", f"int {f}has_prev;"],
        constants=consts, reset=reset, helpers=helper,
        tune=_rate_tune(n, c, ctx.dt),
        step=["{ const double xin = x;",
              f"  x = {c}eval(xin, st->{f}z, st->{f}up, st->{f}has_prev, st->{f}z);",
              f"  st->{f}up = xin;",
              f"  st->{f}has_prev = 1; }}"],
        needs_math=True,
    )


def rate_bisection_step(f: str, c: str) -> list[str]:
    """Step of a rate-dependent inverse: bisect for the input whose output (from the stored
    state, through the stage's ``eval`` helper) is ``x`` within the slope bounds
    ``MLO``/``MHI``, then advance the state with it (rate-dependent PI and Preisach)."""
    return [
        f"{{ const double ref = st->{f}has_prev ? st->{f}up : 0.0;",
        f"  const double f0 = {c}eval(ref, st->{f}z, st->{f}up, st->{f}has_prev, 0);",
        "  double lo, hi; int j;",
        f"  if (x >= f0) {{ lo = ref + (x - f0) / {c}MHI; hi = ref + (x - f0) / {c}MLO; }}",
        f"  else {{ lo = ref + (x - f0) / {c}MLO; hi = ref + (x - f0) / {c}MHI; }}",
        "  for (j = 0; j < 100; ++j) {",
        "      const double mid = 0.5 * (lo + hi);",
        "      if (mid == lo || mid == hi) break;",
        f"      if ({c}eval(mid, st->{f}z, st->{f}up, st->{f}has_prev, 0) < x) lo = mid;",
        "      else hi = mid;",
        "  }",
        "  x = 0.5 * (lo + hi);",
        f"  (void){c}eval(x, st->{f}z, st->{f}up, st->{f}has_prev, st->{f}z);",
        f"  st->{f}up = x;",
        f"  st->{f}has_prev = 1; }}",
    ]


@register_c_stage(RateDependentPIInverse)
def _emit_rate_inverse(model: RateDependentPIInverse, ctx: StageContext) -> CStage:
    """Per-sample bisection of the rate-dependent PI (as ``RateDependentPIInverse``)."""
    assert ctx.dt is not None
    m_lo, m_hi = model.checked_slopes(ctx.dt)
    f, c = ctx.field, ctx.const
    n = model.thresholds.size
    consts, reset, helper = _rate_parts(model, ctx)
    consts += [f"static const double {c}MLO = {c_double(m_lo)};",
               f"static const double {c}MHI = {c_double(m_hi)};"]
    return CStage(
        title=f"inverse rate-dependent PI, {n} play operator(s), per-sample bisection",
        fields=[f"double {f}z[{n}];", f"double {f}up;", f"int {f}has_prev;"],
        constants=consts, reset=reset, helpers=helper,
        tune=[*_rate_tune(n, c, ctx.dt),  # slope bounds as RateDependentPI.slope_bounds
              f"{{ double lo = {c}P0, hi = {c}P0;",
              f"  for (i = 0; i < {n}u; ++i) {{",
              f"      const double a = {c}W[i] * (1.0 - {c}K), b = {c}W[i] * (1.0 + {c}K);",
              "      double mn = 0.0, mx = 0.0;",
              "      if (a < mn) mn = a;",
              "      if (b < mn) mn = b;",
              "      if (a > mx) mx = a;",
              "      if (b > mx) mx = b;",
              "      lo += mn; hi += mx;",
              "  }",
              f"  {c}MLO = lo; {c}MHI = hi; }}"],
        step=rate_bisection_step(f, c),
        needs_math=True,
    )
