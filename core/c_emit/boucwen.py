"""C emitters of the Bouc-Wen model and its inverse (:mod:`core.boucwen`)."""

from __future__ import annotations

from ..boucwen import (
    MAX_SUBSTEPS,
    STEPS_PER_SATURATION,
    BoucWenInverse,
    BoucWenModel,
    saturation_levels,
)
from ..validation import filled
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


def _bouc_wen_parts(
    model: BoucWenModel, ctx: StageContext, solve: bool
) -> tuple[list[str], list[str], list[str], list[str]]:
    """Constants, reset, helpers (``rate``, ``move``; ``at`` and the slope bounds for the
    ``solve`` of the inverse) and tune lines of a Bouc-Wen bank, as
    :func:`core.kernels.bouc_wen_output` (same operations in the same order)."""
    assert isinstance(model, BoucWenModel)
    m = model.n
    f, c = ctx.field, ctx.const
    lo, hi = model.slope_bounds()
    consts = [
        f"static const double {c}K0 = {c_double(model.k)};",
        f"static const double {c}C[{m}] = {c_array(model.weights)};",
        f"static const double {c}B[{m}] = {c_array(model.beta)};",
        f"static const double {c}G[{m}] = {c_array(model.gamma)};",
        f"static const double {c}N[{m}] = {c_array(model.exponent)};",
        f"static const double {c}L[{m}] = "
        f"{c_array(saturation_levels(model.beta, model.gamma, model.exponent))};",
        f"static const double {c}Z0[{m}] = {c_array(filled(model.state0))};",
        f"static const double {c}U0 = {c_double(model.input0)};",
        f"static const double {c}H = {c_double(model.substep)};",
    ]
    if solve:
        consts += [f"static const double {c}MLO = {c_double(lo)};",
                   f"static const double {c}MHI = {c_double(hi)};"]
    helpers = [
        "/* dz/du of one element for an input moving in direction s */",
        f"static double {c}rate(double z, double s, double b, double g, double e)",
        "{",
        "    const double sz = s * z;",
        "    const double sg = sz > 0.0 ? 1.0 : (sz < 0.0 ? -1.0 : 0.0);",
        "    const double a = fabs(z);",
        "    const double p = e == 1.0 ? a : (e == 2.0 ? a * a : pow(a, e));",
        "    return 1.0 - (b * sg + g) * p;",
        "}",
        "/* z limited to [-lim, lim] */",
        f"static double {c}clip(double z, double lim)",
        "{",
        "    if (z > lim) return lim;",
        "    if (z < -lim) return -lim;",
        "    return z;",
        "}",
        "/* advance every element over the input move du (RK4 sub-steps, clipped) */",
        f"static void {c}move(double du, double *z)",
        "{",
        "    double kd, dx, s;",
        "    long K, q;",
        "    unsigned j;",
        "    if (du == 0.0) return;",
        f"    kd = ceil(fabs(du) / {c}H);",
        "    if (kd < 1.0) kd = 1.0;",
        f"    if (kd > {MAX_SUBSTEPS}.0) kd = {MAX_SUBSTEPS}.0;",
        "    K = (long)kd;",
        "    dx = du / kd;",
        "    s = du > 0.0 ? 1.0 : -1.0;",
        f"    for (j = 0; j < {m}u; ++j) {{",
        "        double zj = z[j];",
        f"        const double b = {c}B[j], g = {c}G[j], e = {c}N[j], lim = {c}L[j];",
        "        for (q = 0; q < K; ++q) {",
        f"            const double k1 = {c}rate(zj, s, b, g, e);",
        f"            const double k2 = {c}rate({c}clip(zj + 0.5 * dx * k1, lim), s, b, g, e);",
        f"            const double k3 = {c}rate({c}clip(zj + 0.5 * dx * k2, lim), s, b, g, e);",
        f"            const double k4 = {c}rate({c}clip(zj + dx * k3, lim), s, b, g, e);",
        "            zj += dx * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0;",
        "            if (zj > lim) zj = lim;",
        "            else if (zj < -lim) zj = -lim;",
        "        }",
        "        z[j] = zj;",
        "    }",
        "}",
    ]
    if solve:
        helpers += [
        "/* output at input v reached from (x, z); the variables there go to zt */",
        f"static double {c}at(double v, double x, const double *z, double *zt)",
        "{",
        "    unsigned j;",
        f"    double acc = {c}K0 * v;",
        f"    for (j = 0; j < {m}u; ++j) zt[j] = z[j];",
        f"    {c}move(v - x, zt);",
        f"    for (j = 0; j < {m}u; ++j) acc += {c}C[j] * zt[j];",
        "    return acc;",
        "}",
        ]
    reset = [f"for (i = 0; i < {m}u; ++i) st->{f}z[i] = {c}Z0[i];", f"st->{f}x = {c}U0;"]
    tune = [
        f"{c}K0 = $k[0]; {c}U0 = $input0[0];",
        *([f"{c}MLO = {c}K0; {c}MHI = {c}K0;"] if solve else []),
        f"for (i = 0; i < {m}u; ++i) {{",
        "    const double zs = $saturation[i], sl = $reversal_slope[i], e = $exponent[i];",
        "    const double mx = fabs(sl - 1.0) > 1.0 ? fabs(sl - 1.0) : 1.0;",
        "    const double top = $weights[i] * (sl > 1.0 ? sl : 1.0);",
        f"    const double hj = zs / ({c_double(STEPS_PER_SATURATION)} * (e * mx));",
        f"    {c}C[i] = $weights[i]; {c}N[i] = e; {c}Z0[i] = $state0[i];",
        f"    {c}B[i] = 0.5 * sl * pow(zs, -e);",
        f"    {c}G[i] = 0.5 * (2.0 - sl) * pow(zs, -e);",
        f"    {c}L[i] = {c}B[i] + {c}G[i] > 0.0 ? pow({c}B[i] + {c}G[i], -1.0 / e) : HUGE_VAL;",
        f"    if (i == 0u || hj < {c}H) {c}H = hj;",
        *([f"    if (top < 0.0) {c}MLO += top; else {c}MHI += top;"] if solve else
          ["    (void)top;"]),
        "}",
    ]
    return consts, reset, helpers, tune


@register_c_stage(BoucWenModel)
def _emit_bouc_wen(model: BoucWenModel, ctx: StageContext) -> CStage:
    """Bouc-Wen bank ``x <- k x + sum_j c_j z_j`` (as ``core.kernels.bouc_wen_output``)."""
    f, c = ctx.field, ctx.const
    m = model.n
    consts, reset, helpers, tune = _bouc_wen_parts(model, ctx, False)
    return CStage(
        title=f"rate-independent Bouc-Wen model, {m} element(s)",
        fields=[f"double {f}z[{m}];", f"double {f}x;"], constants=consts, reset=reset,
        helpers=helpers, tune=tune, needs_math=True,
        step=["{ double acc;",
              "  unsigned j;",
              f"  {c}move(x - st->{f}x, st->{f}z);",
              f"  st->{f}x = x;",
              f"  acc = {c}K0 * x;",
              f"  for (j = 0; j < {m}u; ++j) acc += {c}C[j] * st->{f}z[j];",
              "  x = acc; }"],
    )


@register_c_stage(BoucWenInverse)
def _emit_bouc_wen_inverse(model: BoucWenInverse, ctx: StageContext) -> CStage:
    """Per-sample solve of the Bouc-Wen model (as ``core.kernels.bouc_wen_inverse``)."""
    fwd = model.model
    f, c = ctx.field, ctx.const
    m = fwd.n
    consts, reset, helpers, tune = _bouc_wen_parts(fwd, ctx, True)
    tune = [t.replace("$", "$model.") for t in tune]
    helpers += [
        "/* the input whose output from (x, z) is y (regula falsi, Illinois); advances z */",
        f"static double {c}solve(double y, double x, double *z)",
        "{",
        f"    double zt[{m}];",
        f"    double f0 = {c}K0 * x, d, v, a, b, fa, fb, ga, gb, w0, w, t, ft;",
        "    unsigned j;",
        "    int it, side = 0;",
        f"    for (j = 0; j < {m}u; ++j) f0 += {c}C[j] * z[j];",
        "    d = y - f0;",
        "    if (d == 0.0) {",
        "        v = x;",
        "    } else {",
        f"        if (d > 0.0) {{ a = x + d / {c}MHI; b = x + d / {c}MLO; }}",
        f"        else {{ a = x + d / {c}MLO; b = x + d / {c}MHI; }}",
        f"        fa = {c}at(a, x, z, zt) - y;",
        f"        fb = {c}at(b, x, z, zt) - y;",
        "        w0 = b - a;",
        f"        if (w0 <= 0.0) w0 = fabs(d) / {c}MLO;",
        "        w = w0;",
        "        for (it = 0; it < 60; ++it) {",
        "            if (fa <= 0.0) break;",
        "            a -= w; w *= 2.0;",
        f"            fa = {c}at(a, x, z, zt) - y;",
        "        }",
        "        w = w0;",
        "        for (it = 0; it < 60; ++it) {",
        "            if (fb >= 0.0) break;",
        "            b += w; w *= 2.0;",
        f"            fb = {c}at(b, x, z, zt) - y;",
        "        }",
        "        ga = fa; gb = fb;",
        "        for (it = 0; it < 80; ++it) {",
        "            if (ga == 0.0 || gb == 0.0 || ga == gb) break;",
        "            t = (a * gb - b * ga) / (gb - ga);",
        "            if (!(t > a && t < b)) {",
        "                t = 0.5 * (a + b);",
        "                if (!(t > a && t < b)) break;",
        "            }",
        f"            ft = {c}at(t, x, z, zt) - y;",
        "            if (ft <= 0.0) {",
        "                a = t; fa = ft; ga = ft;",
        "                if (side == -1) gb *= 0.5;",
        "                side = -1;",
        "            } else {",
        "                b = t; fb = ft; gb = ft;",
        "                if (side == 1) ga *= 0.5;",
        "                side = 1;",
        "            }",
        "        }",
        "        v = -fa <= fb ? a : b;",
        "    }",
        f"    {c}move(v - x, z);",
        "    return v;",
        "}",
    ]
    return CStage(
        title=f"inverse rate-independent Bouc-Wen model, {m} element(s), per-sample solve",
        fields=[f"double {f}z[{m}];", f"double {f}x;"], constants=consts, reset=reset,
        helpers=helpers, tune=tune, needs_math=True,
        step=[f"x = {c}solve(x, st->{f}x, st->{f}z);", f"st->{f}x = x;"],
    )
