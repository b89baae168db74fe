"""C emitters of the generalized-PI input maps: the dead-zone superposition
(:class:`core.deadzone.DeadZoneMap`) and the tanh envelope with its inverse
(:class:`core.gpi.TanhEnvelope`, :class:`core.gpi.TanhEnvelopeInverse`)."""

from __future__ import annotations

import numpy as np

from ..deadzone import DeadZoneMap
from ..gpi import TanhEnvelope, TanhEnvelopeInverse
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


@register_c_stage(DeadZoneMap)
def _emit_deadzone(model: DeadZoneMap, ctx: StageContext) -> CStage:
    """Dead-zone superposition, evaluated like the Python model: segment, anchor, slope."""
    rho = np.asarray(model.thresholds)
    slopes = np.asarray(model.slopes)
    values = np.asarray(model.breakpoint_values)
    k, c = rho.size, ctx.const
    return CStage(
        title=f"dead-zone superposition, {k} threshold(s), memoryless",
        constants=[
            f"static const double {c}RHO[{k}] = {c_array(rho)};",
            f"static const double {c}SLOPE[{k + 1}] = {c_array(slopes)};",
            f"static const double {c}VAL[{k}] = {c_array(values)};",
        ],
        step=[
            "unsigned seg = 0u;",
            "unsigned anc;",
            f"while (seg < {k}u && {c}RHO[seg] <= x) ++seg;",
            "anc = seg > 0u ? seg - 1u : 0u;",
            f"x = {c}VAL[anc] + {c}SLOPE[seg] * (x - {c}RHO[anc]);",
        ],
        tune=_deadzone_tune(k, int(model.zero_index), c),
    )


def _deadzone_tune(k: int, k0: int, c: str) -> list[str]:
    """Slopes (``DeadZoneMap.slopes``) and breakpoint values (the superposition at each
    threshold) from thresholds and weights; threshold ``k0`` is the linear term's 0."""
    return [
        f"for (i = 0; i < {k}u; ++i) {c}RHO[i] = $thresholds[i];",
        f"{{ double cs = 0.0; {c}SLOPE[{k0}] = $weights[{k0}];",
        f"  for (i = {k0}u; i < {k}u; ++i) {{",
        f"      if (i > {k0}u) cs += $weights[i];",
        f"      {c}SLOPE[i + 1] = $weights[{k0}] + cs;",
        "  }",
        "  cs = 0.0;",
        f"  for (i = {k0}u; i > 0u; --i) {{",
        f"      cs += $weights[i - 1]; {c}SLOPE[i - 1] = $weights[{k0}] + cs;",
        "  } }",
        f"for (i = 0; i < {k}u; ++i) {{",
        "    double acc = 0.0;",
        f"    for (j = 0; j < {k}u; ++j) {{",
        f"        const double d = {c}RHO[i] - {c}RHO[j];",
        f"        const double s = {c}RHO[j] > 0.0 ? (d > 0.0 ? d : 0.0)",
        f"                       : {c}RHO[j] < 0.0 ? (d < 0.0 ? d : 0.0) : {c}RHO[i];",
        "        acc += $weights[j] * s;",
        "    }",
        f"    {c}VAL[i] = acc;",
        "}",
    ]


def _direction_step(f: str) -> list[str]:
    """Update ``st->{f}dir`` from the input direction (a repeated sample keeps it)."""
    return [
        f"if (st->{f}has_prev) {{",
        f"    if (x > st->{f}prev) st->{f}dir = 1;",
        f"    else if (x < st->{f}prev) st->{f}dir = -1;",
        "}",
        f"st->{f}prev = x;",
        f"st->{f}has_prev = 1;",
    ]


def _direction_state(model: TanhEnvelope | TanhEnvelopeInverse, f: str, c: str
                     ) -> tuple[list[str], list[str], list[str]]:
    """Fields, reset and constants of the direction memory (``D0``: initial direction)."""
    d0 = int(model.direction0)
    return (
        [f"double {f}prev;", f"int {f}has_prev;", f"int {f}dir;"],
        [f"st->{f}prev = 0.0;", f"st->{f}has_prev = 0;",
         f"st->{f}dir = {c}D0 > 0.0 ? 1 : -1;"],
        [f"static const double {c}D0 = {c_double(d0)};"],
    )


def _tanh_tune(c: str) -> list[str]:
    return [f"for (i = 0; i < 4u; ++i) {{ {c}A[i] = $a[i]; {c}B[i] = $b[i]; }}",
            f"{c}D0 = $direction0[0] > 0.0 ? 1.0 : -1.0;"]


@register_c_stage(TanhEnvelope)
def _emit_tanh(model: TanhEnvelope, ctx: StageContext) -> CStage:
    """Direction-switching envelope ``c0 tanh(c1 x + c2) + c3`` (a while rising, b falling)."""
    a = np.asarray(model.a)
    b = np.asarray(model.b)
    f, c = ctx.field, ctx.const
    fields, reset, d0 = _direction_state(model, f, c)
    return CStage(
        title="tanh envelope (kappa_R rising, kappa_L falling)",
        fields=fields,
        constants=[
            f"static const double {c}A[4] = {c_array(a)};",
            f"static const double {c}B[4] = {c_array(b)};",
            *d0,
        ],
        tune=_tanh_tune(c),
        reset=reset,
        step=[
            *_direction_step(f),
            f"{{ const double *k = st->{f}dir > 0 ? {c}A : {c}B;",
            "  x = k[0] * tanh(k[1] * x + k[2]) + k[3]; }",
        ],
        needs_math=True,
    )


@register_c_stage(TanhEnvelopeInverse)
def _emit_tanh_inverse(model: TanhEnvelopeInverse, ctx: StageContext) -> CStage:
    """Inverse envelope ``(atanh((x - c3)/c0) - c2)/c1``, clipped to its domain.

    Samples outside ``|x - c3| < (1 - clip_margin)|c0|`` are clipped like the Python model;
    ``st->{field}clipped`` counts them (the Python model warns instead).
    """
    a = np.asarray(model.a)
    b = np.asarray(model.b)
    lim = 1.0 - float(model.clip_margin)
    f, c = ctx.field, ctx.const
    fields, reset, d0 = _direction_state(model, f, c)
    return CStage(
        title="inverse tanh envelope (clips to its domain, counts clipped samples)",
        fields=[*fields, f"unsigned long {f}clipped;"],
        constants=[
            f"static const double {c}A[4] = {c_array(a)};",
            f"static const double {c}B[4] = {c_array(b)};",
            f"static const double {c}LIM = {c_double(lim)};",
            *d0,
        ],
        tune=[*_tanh_tune(c), f"{c}LIM = 1.0 - $clip_margin[0];"],
        reset=[*reset, f"st->{f}clipped = 0ul;"],
        step=[
            *_direction_step(f),
            f"{{ const double *k = st->{f}dir > 0 ? {c}A : {c}B;",
            "  double s = (x - k[3]) / k[0];",
            f"  if (s > {c}LIM) {{ s = {c}LIM; ++st->{f}clipped; }}",
            f"  else if (s < -{c}LIM) {{ s = -{c}LIM; ++st->{f}clipped; }}",
            "  x = (atanh(s) - k[2]) / k[1]; }",
        ],
        needs_math=True,
    )
