"""C emitter of the classical PI model (:class:`core.pi.PIModel`): the play bank."""

from __future__ import annotations

from ..pi import PIModel
from ..validation import filled
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


@register_c_stage(PIModel)
def emit_pi(model: PIModel, ctx: StageContext) -> CStage:
    """Play-operator bank ``x <- p0 x + sum_i w_i z_i`` with ``z_i = clamp(z_i, x-r_i, x+r_i)``."""

    assert isinstance(model, PIModel)
    n = model.n
    f, c = ctx.field, ctx.const
    return CStage(
        title=f"classical PI, {n} play operator(s)",
        fields=[f"double {f}z[{n}];"],
        constants=[
            f"static const double {c}P0 = {c_double(model.p0)};",
            f"static const double {c}R[{n}] = {c_array(model.thresholds)};",
            f"static const double {c}W[{n}] = {c_array(model.weights)};",
            f"static const double {c}Z0[{n}] = {c_array(filled(model.state0))};",
        ],
        reset=[
            f"for (i = 0; i < {n}u; ++i) {{",
            f"    st->{f}z[i] = {c}Z0[i];",
            "}",
        ],
        step=[
            "double acc = 0.0;",
            f"for (i = 0; i < {n}u; ++i) {{",
            f"    const double hi = x + {c}R[i];",
            f"    const double lo = x - {c}R[i];",
            f"    double zi = st->{f}z[i];",
            "    if (zi > hi) zi = hi;",
            "    if (zi < lo) zi = lo;",
            f"    st->{f}z[i] = zi;",
            f"    acc += {c}W[i] * zi;",
            "}",
            f"x = {c}P0 * x + acc;",
        ],
        tune=[
            f"{c}P0 = $p0[0];",
            f"for (i = 0; i < {n}u; ++i) {{",
            f"    {c}R[i] = $thresholds[i]; {c}W[i] = $weights[i]; {c}Z0[i] = $state0[i];",
            "}",
        ],
    )
