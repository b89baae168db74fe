"""C emitters of the linear systems (:class:`core.lti.LinearSystem` and its inverse): a
discrete state space."""

from __future__ import annotations

import numpy as np

from ..lti import InverseLinearSystem, LinearSystem
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


def _emit_state_space(
    Ad: np.ndarray, Bd: np.ndarray, C: np.ndarray, D: float, x0: np.ndarray,
    ctx: StageContext, title: str, x0_field: str = "state0",
) -> CStage:
    """``y = C x + D u``, ``x+ = Ad x + Bd u`` (the update order of ``core.lti.lti_run``);
    the initial state comes from the model field ``x0_field``."""
    n, f, c = int(Bd.size), ctx.field, ctx.const
    if n == 0:
        return CStage(title=title, constants=[f"static const double {c}D = {c_double(D)};"],
                      step=[f"x = {c}D * x;"])
    return CStage(
        title=title,
        fields=[f"double {f}x[{n}];"],
        constants=[
            f"static const double {c}AD[{n * n}] = {c_array(Ad)};",
            f"static const double {c}BD[{n}] = {c_array(Bd)};",
            f"static const double {c}C[{n}] = {c_array(C)};",
            f"static const double {c}D = {c_double(D)};",
            f"static const double {c}X0[{n}] = {c_array(x0)};",
        ],
        reset=[f"for (i = 0; i < {n}u; ++i) st->{f}x[i] = {c}X0[i];"],
        step=[
            f"double acc = {c}D * x;",
            f"double tmp[{n}];",
            "unsigned j;",
            f"for (i = 0; i < {n}u; ++i) acc += {c}C[i] * st->{f}x[i];",
            f"for (i = 0; i < {n}u; ++i) {{",
            f"    double s = {c}BD[i] * x;",
            f"    for (j = 0; j < {n}u; ++j) s += {c}AD[i * {n}u + j] * st->{f}x[j];",
            "    tmp[i] = s;",
            "}",
            f"for (i = 0; i < {n}u; ++i) st->{f}x[i] = tmp[i];",
            "x = acc;",
        ],
        tune=[f"for (i = 0; i < {n}u; ++i) {c}X0[i] = ${x0_field}[i];"],
    )


@register_c_stage(LinearSystem)
def _emit_lti(model: LinearSystem, ctx: StageContext) -> CStage:
    """Linear system, exact ZOH at the ``dt`` given to :func:`generate_c`."""
    assert ctx.dt is not None
    Ad, Bd, C, D = model.discretize(ctx.dt)
    x0 = np.asarray(model.state0, dtype=np.float64)
    return _emit_state_space(np.asarray(Ad), np.asarray(Bd), np.asarray(C), float(D), x0, ctx,
                             f"linear system (ZOH, dt = {ctx.dt:g} s), order {Bd.size}")


@register_c_stage(InverseLinearSystem)
def _emit_lti_inverse(model: InverseLinearSystem, ctx: StageContext) -> CStage:
    """Sampled inverse of a biproper linear system (carries the forward state)."""
    assert ctx.dt is not None
    sys_ = model.system
    Ad, Bd, C, D = (np.asarray(v) for v in sys_.discretize(ctx.dt))
    d = float(D)
    Ai = Ad - np.outer(Bd, C) / d
    x0 = np.asarray(sys_.state0, dtype=np.float64)
    return _emit_state_space(Ai, Bd / d, -C / d, 1.0 / d, x0, ctx,
                             f"inverse linear system (ZOH, dt = {ctx.dt:g} s), order {Bd.size}",
                             "system.state0")
