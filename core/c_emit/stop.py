"""C emitters of the stop (Maxwell-slip) PI model and the gap inverse (:mod:`core.stop`)."""

from __future__ import annotations

import numpy as np

from ..stop import StopGapInverse, StopPIModel
from ..validation import filled
from .pi import emit_pi
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


def _emit_stop_gap(model: StopPIModel, ctx: StageContext) -> CStage:
    """Stop bank behind a backlash gap, step for step as :func:`core.kernels.stop_gap_output`
    (contact while the force keeps its side; the gap opens where it would cross zero)."""
    n, f, c = model.n, ctx.field, ctx.const
    force = [
        f"static double {c}force(double v, const double *z)",
        "{",
        f"    double acc = {c}K * v;",
        "    unsigned i;",
        f"    for (i = 0; i < {n}u; ++i) acc += {c}W[i] * (v - z[i]);",
        "    return acc;",
        "}",
        f"static void {c}clip(double v, double *z)",
        "{",
        "    unsigned i;",
        f"    for (i = 0; i < {n}u; ++i) {{",
        f"        if (z[i] > v + {c}R[i]) z[i] = v + {c}R[i];",
        f"        if (z[i] < v - {c}R[i]) z[i] = v - {c}R[i];",
        "    }",
        "}",
        f"static double {c}zero(double lo, double hi, const double *z, double side)",
        "{",
        f"    double zt[{n}];",
        "    unsigned it, i;",
        "    for (it = 0; it < 80u; ++it) {",
        "        const double mid = 0.5 * (lo + hi);",
        "        if (mid == lo || mid == hi) break;",
        f"        for (i = 0; i < {n}u; ++i) zt[i] = z[i];",
        f"        {c}clip(mid, zt);",
        f"        if ({c}force(mid, zt) * side > 0.0) lo = mid; else hi = mid;",
        "    }",
        "    return hi;",
        "}",
    ]
    z = f"st->{f}z"
    return CStage(
        title=f"stop-operator PI (Maxwell-slip), {n} element(s), behind a backlash gap "
              f"{model.gap:g} wide",
        fields=[f"double {f}z[{n}];", f"double {f}v;", f"double {f}x;"],
        constants=[
            f"static const double {c}K = {c_double(model.k)};",
            f"static const double {c}H = {c_double(0.5 * model.gap)};",
            f"static const double {c}R[{n}] = {c_array(model.thresholds)};",
            f"static const double {c}W[{n}] = {c_array(model.weights)};",
            f"static const double {c}Z0[{n}] = {c_array(filled(model.state0))};",
            f"static const double {c}V0 = {c_double(float(np.mean(filled(model.state0))))};",
        ],
        helpers=force,
        reset=[
            f"for (i = 0; i < {n}u; ++i) {{",
            f"    {z}[i] = {c}Z0[i];",
            "}",
            f"st->{f}v = {c}V0;",
            f"st->{f}x = 0.0;",
        ],
        step=[
            f"double v = st->{f}v, xg = st->{f}x, side;",
            f"if (xg >= {c}H || -xg >= {c}H) {{",
            "    double z1[" + str(n) + "], f0, ft, vt;",
            "    side = xg > 0.0 ? 1.0 : (xg < 0.0 ? -1.0 : 0.0);",
            f"    f0 = {c}force(v, {z});",
            f"    vt = x - side * {c}H;",
            f"    for (i = 0; i < {n}u; ++i) z1[i] = {z}[i];",
            f"    {c}clip(vt, z1);",
            f"    ft = {c}force(vt, z1);",
            "    if (ft * side < 0.0) {",
            f"        if (f0 * side > 0.0) v = {c}zero(v, vt, {z}, side);",
            f"        {c}clip(v, {z});",
            "        xg = x - v;",
            "    } else {",
            "        v = vt;",
            f"        for (i = 0; i < {n}u; ++i) {z}[i] = z1[i];",
            f"        xg = side * {c}H;",
            "    }",
            "} else {",
            "    xg = x - v;",
            "}",
            f"if (xg >= {c}H || -xg >= {c}H) {{  /* (re)closed on the side the input reached */",
            "    side = xg > 0.0 ? 1.0 : -1.0;",
            f"    v = x - side * {c}H;",
            f"    {c}clip(v, {z});",
            f"    xg = side * {c}H;",
            "}",
            f"st->{f}v = v;",
            f"st->{f}x = xg;",
            f"x = (xg >= {c}H || -xg >= {c}H) ? {c}force(v, {z}) : 0.0;",
        ],
    )


@register_c_stage(StopGapInverse)
def _emit_stop_gap_inverse(model: StopGapInverse, ctx: StageContext) -> CStage:
    """The element bank's play-type PI inverse plus the gap side ``(b/2) sign(y)`` (held at
    ``y = 0``)."""
    assert isinstance(model, StopGapInverse)
    stage = emit_pi(model.model, ctx)
    f, c = ctx.field, ctx.const
    stage.title = f"inverse of a stop-operator PI behind a backlash gap {model.gap:g} wide"
    stage.fields.append(f"double {f}side;")
    stage.constants.append(f"static const double {c}H = {c_double(0.5 * model.gap)};")
    stage.reset.append(f"st->{f}side = 0.0;")
    stage.step = [
        "const double force = x;",
        f"if (force > 0.0) st->{f}side = 1.0;",
        f"if (force < 0.0) st->{f}side = -1.0;",
        "{",
        *(f"    {line}" for line in stage.step),
        "}",
        f"x = x + {c}H * st->{f}side;",
    ]
    stage.tune = []
    return stage


@register_c_stage(StopPIModel)
def _emit_stop_pi(model: StopPIModel, ctx: StageContext) -> CStage:
    """Stop-operator bank (Maxwell-slip) as its play-type PI, ``p0 = k + sum w_i`` and
    ``p_i = -w_i`` (``x - z_i`` is stop ``i``'s output): the PI's stage, with constants
    tuned from the stop fields."""

    assert isinstance(model, StopPIModel)
    if model.gap > 0:
        return _emit_stop_gap(model, ctx)
    stage = emit_pi(model.equivalent_pi(), ctx)
    n, c = model.n, ctx.const
    stage.title = f"stop-operator PI (Maxwell-slip), {n} element(s)"
    stage.tune = [
        f"{c}P0 = $k[0];",
        f"for (i = 0; i < {n}u; ++i) {{",
        f"    {c}R[i] = $thresholds[i]; {c}W[i] = -$weights[i]; {c}Z0[i] = $state0[i];",
        f"    {c}P0 += $weights[i];",
        "}",
    ]
    return stage
