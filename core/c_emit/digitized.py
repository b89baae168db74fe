"""C emitters of the digitized PI models (:class:`core.digitized.DigitizedPI`,
:class:`core.digitized_deadzone.DigitizedDeadZone`): the snapped state lattice."""

from __future__ import annotations

import numpy as np

from ..digitized import SNAP_RTOL, DigitizedPI
from ..digitized_deadzone import DigitizedDeadZone
from .stage import (
    CStage,
    StageContext,
    c_array,
    c_double,
    register_c_stage,
)


@register_c_stage(DigitizedPI)
def _emit_digitized(model: DigitizedPI, ctx: StageContext) -> CStage:
    """Digitized PI (paper 000): binary digits in the state, same snapping rule as Python."""
    dx = np.asarray(model.dx)
    dy = np.asarray(model.dy)
    g = np.asarray(model.slopes)
    d0 = np.asarray(model.state0, dtype=np.float64)
    n, f, c = dx.size, ctx.field, ctx.const
    return CStage(
        title=f"digitized PI, {n} digit(s)",
        fields=[f"unsigned char {f}b[{n}];"],
        constants=[
            f"static const double {c}DX[{n}] = {c_array(dx)};",
            f"static const double {c}DY[{n}] = {c_array(dy)};",
            f"static const double {c}G[{n}] = {c_array(g)};",
            f"static const unsigned char {c}B0[{n}] = {{"
            + ", ".join(str(int(v)) for v in d0) + "};",
            f"static const double {c}X0 = {c_double(model.x0)};",
            f"static const double {c}Y0 = {c_double(model.y0)};",
            f"static const double {c}TOL = {c_double(model.tol)};",
        ],
        helpers=[
            "/* state point (X_B, Y_B) and lowest 0 / 1 digit of the digits b (-1: none) */",
            f"static void {c}point(const unsigned char *b, double *xb, double *yb, int *lo0,",
            "                     int *lo1)",
            "{",
            "    unsigned k;",
            f"    *xb = {c}X0;",
            f"    *yb = {c}Y0;",
            "    *lo0 = -1;",
            "    *lo1 = -1;",
            f"    for (k = 0; k < {n}u; ++k) {{",
            "        if (b[k]) {",
            f"            *xb += {c}DX[k];",
            f"            *yb += {c}DY[k];",
            "            if (*lo1 < 0) *lo1 = (int)k;",
            "        } else if (*lo0 < 0) {",
            "            *lo0 = (int)k;",
            "        }",
            "    }",
            "}",
        ],
        reset=[f"for (i = 0; i < {n}u; ++i) st->{f}b[i] = {c}B0[i];"],
        tune=[  # as DigitizedPI: slopes dy/dx, snapping tolerance from dx (DigitizedPI.tol)
            "{ double span = 0.0, scale;",
            f"  for (i = 0; i < {n}u; ++i) {{",
            f"      {c}DX[i] = $dx[i]; {c}DY[i] = $dy[i]; {c}G[i] = {c}DY[i] / {c}DX[i];",
            f"      {c}B0[i] = (unsigned char)($state0[i] != 0.0); span += {c}DX[i];",
            "  }",
            f"  {c}X0 = $x0[0]; {c}Y0 = $y0[0];",
            f"  scale = fabs({c}X0) > fabs({c}X0 + span) ? fabs({c}X0) : fabs({c}X0 + span);",
            "  if (span > scale) scale = span;",
            f"  {c}TOL = {c_double(SNAP_RTOL)} * {c}DX[0]"
            f" + ({float(n + 8)} * {c_double(float(np.finfo(np.float64).eps))}) * scale; }}",
        ],
        step=[
            "double xb, yb;",
            "int lo0, lo1, moved = 0;",
            f"{c}point(st->{f}b, &xb, &yb, &lo0, &lo1);",
            f"while (lo0 >= 0 && x >= xb + {c}DX[lo0] - {c}TOL) {{",
            f"    st->{f}b[lo0] = 1;",
            "    moved = 1;",
            f"    {c}point(st->{f}b, &xb, &yb, &lo0, &lo1);",
            "}",
            "if (!moved) {",
            f"    while (lo1 >= 0 && x <= xb - {c}DX[lo1] + {c}TOL) {{",
            f"        st->{f}b[lo1] = 0;",
            f"        {c}point(st->{f}b, &xb, &yb, &lo0, &lo1);",
            "    }",
            "}",
            "if (x >= xb) {",
            f"    x = yb + {c}G[lo0 >= 0 ? lo0 : {n - 1}] * (x - xb);",
            "} else {",
            f"    x = yb + {c}G[lo1 >= 0 ? lo1 : {n - 1}] * (x - xb);",
            "}",
        ],
    )


@register_c_stage(DigitizedDeadZone)
def _emit_digitized_deadzone(model: DigitizedDeadZone, ctx: StageContext) -> CStage:
    """Digitized dead-zone superposition (paper 000): the current segment is the state."""
    dx = np.asarray(model.dx)
    dy = np.asarray(model.dy)
    x0, y0 = float(model.x0), float(model.y0)
    g = np.asarray(model.slopes)
    xl = x0 + np.concatenate(([0.0], np.cumsum(dx)[:-1]))
    yl = y0 + np.concatenate(([0.0], np.cumsum(dy)[:-1]))
    m, f, c = dx.size, ctx.field, ctx.const
    c0 = int(model.state0) - 1
    return CStage(
        title=f"digitized dead zone, {m} segment(s)",
        fields=[f"unsigned {f}seg;"],
        constants=[
            f"static const double {c}DX[{m}] = {c_array(dx)};",
            f"static const double {c}G[{m}] = {c_array(g)};",
            f"static const double {c}XL[{m}] = {c_array(xl)};",
            f"static const double {c}YL[{m}] = {c_array(yl)};",
            f"static const double {c}SEG0 = {c_double(c0)};",
        ],
        reset=[f"st->{f}seg = (unsigned){c}SEG0;"],
        tune=[  # segment starts by cumulative sums, as DigitizedDeadZone
            "{ double cx = 0.0, cy = 0.0;",
            f"  for (i = 0; i < {m}u; ++i) {{",
            f"      {c}DX[i] = $dx[i]; {c}G[i] = $dy[i] / $dx[i];",
            f"      {c}XL[i] = $x0[0] + cx; {c}YL[i] = $y0[0] + cy; cx += $dx[i]; cy += $dy[i];",
            "  }",
            f"  {c}SEG0 = $state0[0] < 1.0 ? 0.0 : $state0[0] > {float(m)} ? {float(m - 1)}"
            f" : floor($state0[0]) - 1.0; }}",
        ],
        step=[
            f"unsigned k = st->{f}seg;",
            f"while (k < {m - 1}u && x > {c}XL[k] + {c}DX[k]) ++k;",
            f"while (k > 0u && x < {c}XL[k]) --k;",
            f"st->{f}seg = k;",
            f"x = {c}YL[k] + {c}G[k] * (x - {c}XL[k]);",
        ],
    )
