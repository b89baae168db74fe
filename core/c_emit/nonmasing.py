"""C emitters of the Menegotto-Pinto bank and its inverse (:mod:`core.nonmasing`).

The generated state is the model's own state vector (:func:`core.nonmasing.state_size`
numbers, the layout of :func:`core.kernels.mp_advance`), so a C run, a Python run and an FMU
carry the same memory from sample to sample; the element update, the output and the
inverse's solve do the operations of :func:`core.kernels.mp_advance`,
:func:`core.kernels.mp_output` and :func:`core.kernels.mp_inverse` in the same order.
"""

from __future__ import annotations

import numpy as np

from ..nonmasing import MenegottoPintoInverse, MenegottoPintoModel, state_size
from .stage import (
    CExportError,
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


def _parts(model: MenegottoPintoModel, ctx: StageContext, solve: bool
           ) -> tuple[list[str], list[str], list[str], list[str]]:
    """Constants, reset, helpers (``unit``, ``advance``, ``out``; ``at`` and ``solve`` for
    the inverse) and tune lines of a bank of ``model.n`` elements."""
    n, f, c = model.n, ctx.field, ctx.const
    size = state_size(n)
    with np.errstate(over="ignore"):
        lo, hi = model.slope_bounds()
    if solve and not (np.isfinite(lo) and np.isfinite(hi)):
        raise CExportError(
            f"the Menegotto-Pinto compensator brackets each sample between the branch slopes "
            f"{lo:g} and {hi:g} (k plus the negative, and plus the positive, element moduli), "
            "which overflow a double; scale k and the weights down (e.g. express the output "
            "in a larger unit) and export again"
        )
    consts = [
        f"static const double {c}K = {c_double(model.k)};",
        f"static const double {c}R[{n}] = {c_array(model.thresholds)};",
        f"static const double {c}W[{n}] = {c_array(model.weights)};",
        f"static const double {c}C0[{n}] = {c_array(model.curvature)};",
        f"static const double {c}C1[{n}] = {c_array(model.curvature_drop)};",
        f"static const double {c}C2[{n}] = {c_array(model.curvature_scale)};",
    ]
    hist = model.history if model.history is not None else np.zeros(0)
    if hist.size:  # the memory the record starts with: run from rest at every reset
        consts.append(f"static const double {c}H[{hist.size}] = {c_array(hist)};")
    if solve:
        consts += [f"static const double {c}MLO = {c_double(lo)};",
                   f"static const double {c}MHI = {c_double(hi)};"]
    helpers = [
        "/* x / (1 + |x|^R)^(1/R) without overflow or underflow for a large R */",
        f"static double {c}unit(double x, double rr)",
        "{",
        "    const double ax = fabs(x);",
        "    double v;",
        "    if (ax <= 1.0) return x / pow(1.0 + pow(ax, rr), 1.0 / rr);",
        "    v = 1.0 / pow(1.0 + pow(ax, -rr), 1.0 / rr);",
        "    return x > 0.0 ? v : -v;",
        "}",
        "/* move the state to the input v: a reversal where the direction changes starts a new",
        "   branch of every element (curvature from its previous excursion), then each",
        "   element's output on its branch */",
        f"static void {c}advance(double v, double *st)",
        "{",
        "    const double u = st[0];",
        "    double d = st[1], nd;",
        "    const double du = v - u;",
        "    unsigned i;",
        "    nd = du > 0.0 ? 1.0 : (du < 0.0 ? -1.0 : 0.0);",
        "    if (nd != 0.0 && nd != d) {",
        f"        for (i = 0; i < {n}u; ++i) {{",
        "            double *e = st + 3 + 5 * i;",
        "            double ua, um, xi;",
        "            if (d > 0.0) { if (u > e[2]) e[2] = u; }",
        "            else if (d < 0.0) { if (u < e[3]) e[3] = u; }",
        "            e[1] = e[0];",
        f"            ua = u + nd * {c}R[i] - e[0];",
        "            um = nd > 0.0 ? e[2] : e[3];",
        f"            xi = fabs(um - ua) / {c}R[i];",
        f"            e[4] = {c}C0[i] * (1.0 - {c}C1[i] * xi / ({c}C2[i] + xi));",
        "        }",
        "        st[1] = nd;",
        "        st[2] = u;",
        "        d = nd;",
        "    }",
        "    st[0] = v;",
        "    if (d != 0.0) {",
        "        const double ur = st[2];",
        f"        for (i = 0; i < {n}u; ++i) {{",
        "            double *e = st + 3 + 5 * i;",
        f"            const double span = d * {c}R[i] - e[1];",
        f"            if (span != 0.0) e[0] = e[1] + span * {c}unit((v - ur) / span, e[4]);",
        "        }",
        "    }",
        "}",
        "/* the output k v + sum_i w_i s_i of the state reached at input v */",
        f"static double {c}out(double v, const double *st)",
        "{",
        f"    double y = {c}K * v;",
        "    unsigned i;",
        f"    for (i = 0; i < {n}u; ++i) y += {c}W[i] * st[3 + 5 * i];",
        "    return y;",
        "}",
    ]
    if solve:
        helpers += [
            "/* the output at input v from the state st (left unchanged) */",
            f"static double {c}at(double v, const double *st)",
            "{",
            f"    double wk[{size}];",
            "    unsigned j;",
            f"    for (j = 0; j < {size}u; ++j) wk[j] = st[j];",
            f"    {c}advance(v, wk);",
            f"    return {c}out(v, wk);",
            "}",
            "/* the input whose output from the state is y: bracketed from the slopes, regula",
            "   falsi (Illinois) with a bisection every fourth step, to adjacent doubles; the",
            "   state advances to it */",
            f"static double {c}solve(double y, double *st)",
            "{",
            "    const double x = st[0];",
            f"    const double dd = y - {c}out(x, st);",
            "    double v = x;",
            "    if (dd != 0.0) {",
            "        double a, b, fa, fb, ga, gb, w0, ww, tt, ft;",
            "        int it, side = 0;",
            f"        if (dd > 0.0) {{ a = x + dd / {c}MHI; b = x + dd / {c}MLO; }}",
            f"        else {{ a = x + dd / {c}MLO; b = x + dd / {c}MHI; }}",
            f"        fa = {c}at(a, st) - y;",
            f"        fb = {c}at(b, st) - y;",
            f"        w0 = fabs(dd) / {c}MLO;",
            "        ww = w0;",
            "        for (it = 0; it < 60; ++it) {",
            "            if (fa <= 0.0) break;",
            "            a -= ww; ww *= 2.0;",
            f"            fa = {c}at(a, st) - y;",
            "        }",
            "        ww = w0;",
            "        for (it = 0; it < 60; ++it) {",
            "            if (fb >= 0.0) break;",
            "            b += ww; ww *= 2.0;",
            f"            fb = {c}at(b, st) - y;",
            "        }",
            "        ga = fa; gb = fb;",
            "        for (it = 0; it < 200; ++it) {",
            "            if (ga == 0.0 || gb == 0.0) break;",
            "            if (it % 4 == 3 || ga == gb) tt = 0.5 * (a + b);",
            "            else tt = (a * gb - b * ga) / (gb - ga);",
            "            if (!(tt > a && tt < b)) {",
            "                tt = 0.5 * (a + b);",
            "                if (!(tt > a && tt < b)) break;",
            "            }",
            f"            ft = {c}at(tt, st) - y;",
            "            if (ft <= 0.0) {",
            "                a = tt; fa = ft; ga = ft;",
            "                if (side == -1) gb *= 0.5;",
            "                side = -1;",
            "            } else {",
            "                b = tt; fb = ft; gb = ft;",
            "                if (side == 1) ga *= 0.5;",
            "                side = 1;",
            "            }",
            "        }",
            "        if (fa == 0.0) v = a;",
            "        else if (fb == 0.0) v = b;",
            "        else v = dd > 0.0 ? a : b;  /* short of the target: a held one never "
            "steps back */",
            "        if ((v - x) * dd < 0.0) v = x;  /* round-off against the target's side */",
            "    }",
            f"    {c}advance(v, st);",
            "    return v;",
            "}",
        ]
    reset = [
        f"for (i = 0; i < {size}u; ++i) st->{f}st[i] = 0.0;",
        f"for (i = 0; i < {n}u; ++i) {{",
        f"    st->{f}st[5 + 5 * i] = {c}R[i];",
        f"    st->{f}st[6 + 5 * i] = -{c}R[i];",
        f"    st->{f}st[7 + 5 * i] = {c}C0[i];",
        "}",
        *([f"for (i = 0; i < {hist.size}u; ++i) {c}advance({c}H[i], st->{f}st);"]
          if hist.size else []),
    ]
    tune = [
        f"{c}K = $k[0];",
        *([f"{c}MLO = {c}K; {c}MHI = {c}K;"] if solve else []),
        f"for (i = 0; i < {n}u; ++i) {{",
        f"    {c}R[i] = $thresholds[i]; {c}W[i] = $weights[i];",
        f"    {c}C0[i] = $curvature[i]; {c}C1[i] = $curvature_drop[i];",
        f"    {c}C2[i] = $curvature_scale[i];",
        # the model's rule cR1 < 1 (the field's limit admits 1): refused as non-finite
        f"    if (!({c}C1[i] < 1.0)) {c}C1[i] = NAN;",
        *([f"    if ({c}W[i] < 0.0) {c}MLO += {c}W[i]; else {c}MHI += {c}W[i];"]
          if solve else []),
        "}",
        # a flat or falling branch has no inverse: refused as a non-finite constant
        *([f"if (!({c}MLO > 0.0)) {c}MLO = NAN;"] if solve else []),
    ]
    return consts, reset, helpers, tune


@register_c_stage(MenegottoPintoModel)
def _emit_menegotto_pinto(model: MenegottoPintoModel, ctx: StageContext) -> CStage:
    """The bank ``x <- k x + sum_i w_i s_i[x]`` (as :func:`core.kernels.mp_output`)."""
    assert isinstance(model, MenegottoPintoModel)
    f, c = ctx.field, ctx.const
    consts, reset, helpers, tune = _parts(model, ctx, False)
    return CStage(
        title=f"Menegotto-Pinto smooth stop elements (non-Masing), {model.n} element(s)",
        fields=[f"double {f}st[{state_size(model.n)}];"], constants=consts, reset=reset,
        helpers=helpers, tune=tune, needs_math=True,
        step=[f"{c}advance(x, st->{f}st);", f"x = {c}out(x, st->{f}st);"],
    )


@register_c_stage(MenegottoPintoInverse)
def _emit_menegotto_pinto_inverse(model: MenegottoPintoInverse, ctx: StageContext) -> CStage:
    """Per-sample solve of the bank (as :func:`core.kernels.mp_inverse`)."""
    assert isinstance(model, MenegottoPintoInverse)
    fwd = model.model
    f, c = ctx.field, ctx.const
    consts, reset, helpers, tune = _parts(fwd, ctx, True)
    return CStage(
        title=f"inverse of Menegotto-Pinto smooth stop elements, {fwd.n} element(s), "
              "per-sample solve",
        fields=[f"double {f}st[{state_size(fwd.n)}];"], constants=consts, reset=reset,
        helpers=helpers, tune=[t.replace("$", "$model.") for t in tune], needs_math=True,
        step=[f"x = {c}solve(x, st->{f}st);"],
    )
