"""C99 code generation: the inverse compensator (and the forward model) for embedded use.

The generated code runs sample by sample with no allocation: all state lives in a struct
the caller owns, every constant is emitted with ``%.17g`` (exact round trip of IEEE doubles),
and the API of a generated block ``<name>`` is::

    typedef struct { ... } <name>_state;
    void   <name>_init(<name>_state *st);            /* first use: same as reset */
    void   <name>_reset(<name>_state *st);           /* back to the model's initial state */
    double <name>_step(<name>_state *st, double u);  /* one sample in, one sample out */
    void   <name>_run(<name>_state *st, const double *u, double *y, size_t n);

:func:`generate_c` emits the inverse compensator as ``<prefix>_inv_*`` and, optionally, the
forward model as ``<prefix>_fwd_*``. The generator is stage based: a model is flattened into
its chain stages and each stage type contributes struct fields, constants, reset statements
and step statements through an emitter registered with :func:`register_c_stage`, so new model
types plug in without touching the rest. Stage types with an emitter: see
:func:`supported_c_types`.
"""

from __future__ import annotations

import re
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .base import Chain, Model
from .boucwen import (
    MAX_SUBSTEPS,
    STEPS_PER_SATURATION,
    BoucWenInverse,
    BoucWenModel,
    saturation_levels,
)
from .deadzone import DeadZoneMap
from .digitized import SNAP_RTOL, DigitizedPI
from .digitized_deadzone import DigitizedDeadZone
from .effects import (
    Advance,
    Asymmetry,
    AsymmetryInverse,
    Creep,
    CreepInverse,
    Delay,
    Drift,
    Lag,
    LagInverse,
    Offset,
    RateDependentPI,
    RateDependentPIInverse,
    Resonance,
    ResonanceInverse,
    bisect_steps,
    delay_split,
    discretised_tf,
)
from .escape import c_comment
from .exceptions import ParameterError
from .gpi import TanhEnvelope, TanhEnvelopeInverse
from .lti import InverseLinearSystem, LinearSystem
from .pi import PIModel
from .preisach import (
    PreisachInverse,
    PreisachModel,
    RateDependentPreisach,
    RateDependentPreisachInverse,
)
from .stop import StopGapInverse, StopPIModel

if TYPE_CHECKING:
    from .paramset import ParameterSet

__all__ = [
    "CCode",
    "CExportError",
    "CStage",
    "StageContext",
    "c_identifier",
    "causal_compensator",
    "c_double",
    "export_c",
    "generate_c",
    "register_c_stage",
    "emitter_for",
    "supported_c_types",
]

_C_KEYWORDS = frozenset(
    "auto break case char const continue default do double else enum extern float for goto if "
    "inline int long register restrict return short signed sizeof static struct switch typedef "
    "union unsigned void volatile while _Bool _Complex _Imaginary".split()
)


class CExportError(ParameterError):
    """The model cannot be exported to C (unsupported stage type, bad name, ...)."""


def c_double(x: float) -> str:
    """A C double literal with 17 significant digits (exact round trip).

    Examples
    --------
    >>> c_double(0.1)
    '0.10000000000000001'
    >>> c_double(2.0)
    '2.0'
    """
    v = float(x)
    if not np.isfinite(v):
        raise CExportError(f"cannot emit the non-finite constant {v!r} as C code")
    s = format(v, ".17g")
    if not any(c in s for c in ".en"):
        s += ".0"
    return s


def _c_array(values: Sequence[float] | np.ndarray, per_line: int = 4) -> str:
    items = [c_double(v) for v in np.asarray(values, dtype=np.float64).ravel()]
    lines = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    return "{\n    " + ",\n    ".join(lines) + "\n}"


@dataclass
class CStage:
    """C fragments of one stage, with identifiers already prefixed.

    Attributes
    ----------
    title : str
        One-line description for the comment above the stage.
    fields : list of str
        Declarations inside the state struct, e.g. ``"double s0_z[6];"``.
    constants : list of str
        File-scope ``static const`` definitions.
    reset : list of str
        Statements that put the state (``st->...``) back to its initial value.
    step : list of str
        Statements that read the current sample from the double ``x`` and overwrite ``x``
        with the stage output (they may update ``st->...``). The loop counter ``unsigned
        i`` is declared by the caller when any line contains ``for (i``.
    helpers : list of str
        File-scope ``static`` helper functions (identifiers prefixed with ``ctx.const``).
    needs_math : bool
        Whether the code calls ``<math.h>`` functions (``tanh``, ``atanh``).
    tune : list of str
        Statements that recompute the stage's constants from its model parameters, for
        exports whose parameters can be changed at run time (the FMU,
        :mod:`core.export_fmu`). ``$field[i]`` stands for element ``i`` of the model field
        ``field`` (``$model.thresholds[i]`` for a nested model; matrices row by row); the
        loop counters ``unsigned i, j`` are declared by the caller. A field named in no line
        is fixed at export (its derived constants need the export's numerics).
    tune_helpers : list of str
        File-scope ``static`` functions the tune lines call (emitted with them only).
    """

    title: str
    fields: list[str] = field(default_factory=list)
    constants: list[str] = field(default_factory=list)
    reset: list[str] = field(default_factory=list)
    step: list[str] = field(default_factory=list)
    helpers: list[str] = field(default_factory=list)
    needs_math: bool = False
    tune: list[str] = field(default_factory=list)
    tune_helpers: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class StageContext:
    """Naming and timing context handed to a stage emitter.

    Attributes
    ----------
    field : str
        Prefix of the stage's struct fields (``"s0_"``), unique within a block.
    const : str
        Prefix of the stage's file-scope constants (``"hyst_inv_s0_"``), unique in the file.
    dt : float or None
        Sample time in seconds for dynamic stages.
    """

    field: str
    const: str
    dt: float | None = None


#: Emitter signature: ``(model, ctx) -> CStage``.
Emitter = Callable[[Model, StageContext], CStage]
_EMITTERS: dict[type[Model], Emitter] = {}


def register_c_stage(cls: type[Model]) -> Callable[[Emitter], Emitter]:
    """Decorator registering the C emitter of model class ``cls`` (see :class:`CStage`);
    :func:`emitter_for` dispatches on the class (a subclass uses its parent's emitter
    unless it registers its own)."""

    def deco(fn: Emitter) -> Emitter:
        _EMITTERS[cls] = fn
        return fn

    return deco


def emitter_for(model: Model) -> Emitter | None:
    """The C emitter of ``model``'s class or of its nearest registered base class."""
    return next((_EMITTERS[c] for c in type(model).__mro__ if c in _EMITTERS), None)


def supported_c_types() -> list[str]:
    """Model types that :func:`generate_c` can emit (``chain`` of these included)."""
    return sorted(c.type_name for c in _EMITTERS)


# ----------------------------------------------------------------------------- stage emitters
@register_c_stage(PIModel)
def _emit_pi(model: Model, ctx: StageContext) -> CStage:
    """Play-operator bank ``x <- p0 x + sum_i w_i z_i`` with ``z_i = clamp(z_i, x-r_i, x+r_i)``."""

    assert isinstance(model, PIModel)
    n = model.n
    f, c = ctx.field, ctx.const
    return CStage(
        title=f"classical PI, {n} play operator(s)",
        fields=[f"double {f}z[{n}];"],
        constants=[
            f"static const double {c}P0 = {c_double(model.p0)};",
            f"static const double {c}R[{n}] = {_c_array(model.thresholds)};",
            f"static const double {c}W[{n}] = {_c_array(model.weights)};",
            f"static const double {c}Z0[{n}] = {_c_array(model.state0)};",
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


@register_c_stage(Offset)
def _emit_offset(model: Model, ctx: StageContext) -> CStage:
    """Constant output offset ``x <- x + c``."""
    c = float(model.offset)  # type: ignore[attr-defined]
    return CStage(
        title="output offset",
        constants=[f"static const double {ctx.const}C = {c_double(c)};"],
        step=[f"x = x + {ctx.const}C;"],
        tune=[f"{ctx.const}C = $offset[0];"],
    )


@register_c_stage(DeadZoneMap)
def _emit_deadzone(model: Model, ctx: StageContext) -> CStage:
    """Dead-zone superposition, evaluated like the Python model: segment, anchor, slope."""
    rho = np.asarray(model.thresholds)  # type: ignore[attr-defined]
    slopes = np.asarray(model.slopes)  # type: ignore[attr-defined]
    values = np.asarray(model.breakpoint_values)  # type: ignore[attr-defined]
    k, c = rho.size, ctx.const
    return CStage(
        title=f"dead-zone superposition, {k} threshold(s), memoryless",
        constants=[
            f"static const double {c}RHO[{k}] = {_c_array(rho)};",
            f"static const double {c}SLOPE[{k + 1}] = {_c_array(slopes)};",
            f"static const double {c}VAL[{k}] = {_c_array(values)};",
        ],
        step=[
            "unsigned seg = 0u;",
            "unsigned anc;",
            f"while (seg < {k}u && {c}RHO[seg] <= x) ++seg;",
            "anc = seg > 0u ? seg - 1u : 0u;",
            f"x = {c}VAL[anc] + {c}SLOPE[seg] * (x - {c}RHO[anc]);",
        ],
        tune=_deadzone_tune(k, int(model.zero_index), c),  # type: ignore[attr-defined]
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


def _direction_state(model: Model, f: str, c: str) -> tuple[list[str], list[str], list[str]]:
    """Fields, reset and constants of the direction memory (``D0``: initial direction)."""
    d0 = int(model.direction0)  # type: ignore[attr-defined]
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
def _emit_tanh(model: Model, ctx: StageContext) -> CStage:
    """Direction-switching envelope ``c0 tanh(c1 x + c2) + c3`` (a while rising, b falling)."""
    a = np.asarray(model.a)  # type: ignore[attr-defined]
    b = np.asarray(model.b)  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    fields, reset, d0 = _direction_state(model, f, c)
    return CStage(
        title="tanh envelope (kappa_R rising, kappa_L falling)",
        fields=fields,
        constants=[
            f"static const double {c}A[4] = {_c_array(a)};",
            f"static const double {c}B[4] = {_c_array(b)};",
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
def _emit_tanh_inverse(model: Model, ctx: StageContext) -> CStage:
    """Inverse envelope ``(atanh((x - c3)/c0) - c2)/c1``, clipped to its domain.

    Samples outside ``|x - c3| < (1 - clip_margin)|c0|`` are clipped like the Python model;
    ``st->{field}clipped`` counts them (the Python model warns instead).
    """
    a = np.asarray(model.a)  # type: ignore[attr-defined]
    b = np.asarray(model.b)  # type: ignore[attr-defined]
    lim = 1.0 - float(model.clip_margin)  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    fields, reset, d0 = _direction_state(model, f, c)
    return CStage(
        title="inverse tanh envelope (clips to its domain, counts clipped samples)",
        fields=[*fields, f"unsigned long {f}clipped;"],
        constants=[
            f"static const double {c}A[4] = {_c_array(a)};",
            f"static const double {c}B[4] = {_c_array(b)};",
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


@register_c_stage(DigitizedPI)
def _emit_digitized(model: Model, ctx: StageContext) -> CStage:
    """Digitized PI (paper 000): binary digits in the state, same snapping rule as Python."""
    dx = np.asarray(model.dx)  # type: ignore[attr-defined]
    dy = np.asarray(model.dy)  # type: ignore[attr-defined]
    g = np.asarray(model.slopes)  # type: ignore[attr-defined]
    d0 = np.asarray(model.state0, dtype=np.float64)  # type: ignore[attr-defined]
    n, f, c = dx.size, ctx.field, ctx.const
    return CStage(
        title=f"digitized PI, {n} digit(s)",
        fields=[f"unsigned char {f}b[{n}];"],
        constants=[
            f"static const double {c}DX[{n}] = {_c_array(dx)};",
            f"static const double {c}DY[{n}] = {_c_array(dy)};",
            f"static const double {c}G[{n}] = {_c_array(g)};",
            f"static const unsigned char {c}B0[{n}] = {{"
            + ", ".join(str(int(v)) for v in d0) + "};",
            f"static const double {c}X0 = {c_double(model.x0)};",  # type: ignore[attr-defined]
            f"static const double {c}Y0 = {c_double(model.y0)};",  # type: ignore[attr-defined]
            f"static const double {c}TOL = {c_double(model.tol)};",  # type: ignore[attr-defined]
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
def _emit_digitized_deadzone(model: Model, ctx: StageContext) -> CStage:
    """Digitized dead-zone superposition (paper 000): the current segment is the state."""
    dx = np.asarray(model.dx)  # type: ignore[attr-defined]
    dy = np.asarray(model.dy)  # type: ignore[attr-defined]
    x0, y0 = float(model.x0), float(model.y0)  # type: ignore[attr-defined]
    g = np.asarray(model.slopes)  # type: ignore[attr-defined]
    xl = x0 + np.concatenate(([0.0], np.cumsum(dx)[:-1]))
    yl = y0 + np.concatenate(([0.0], np.cumsum(dy)[:-1]))
    m, f, c = dx.size, ctx.field, ctx.const
    c0 = int(model.state0) - 1  # type: ignore[attr-defined]
    return CStage(
        title=f"digitized dead zone, {m} segment(s)",
        fields=[f"unsigned {f}seg;"],
        constants=[
            f"static const double {c}DX[{m}] = {_c_array(dx)};",
            f"static const double {c}G[{m}] = {_c_array(g)};",
            f"static const double {c}XL[{m}] = {_c_array(xl)};",
            f"static const double {c}YL[{m}] = {_c_array(yl)};",
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
            f"static const double {c}AD[{n * n}] = {_c_array(Ad)};",
            f"static const double {c}BD[{n}] = {_c_array(Bd)};",
            f"static const double {c}C[{n}] = {_c_array(C)};",
            f"static const double {c}D = {c_double(D)};",
            f"static const double {c}X0[{n}] = {_c_array(x0)};",
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
def _emit_lti(model: Model, ctx: StageContext) -> CStage:
    """Linear system, exact ZOH at the ``dt`` given to :func:`generate_c`."""
    assert ctx.dt is not None
    Ad, Bd, C, D = model.discretize(ctx.dt)  # type: ignore[attr-defined]
    x0 = np.asarray(model.state0, dtype=np.float64)  # type: ignore[attr-defined]
    return _emit_state_space(np.asarray(Ad), np.asarray(Bd), np.asarray(C), float(D), x0, ctx,
                             f"linear system (ZOH, dt = {ctx.dt:g} s), order {Bd.size}")


@register_c_stage(InverseLinearSystem)
def _emit_lti_inverse(model: Model, ctx: StageContext) -> CStage:
    """Sampled inverse of a biproper linear system (carries the forward state)."""
    assert ctx.dt is not None
    sys_ = model.system  # type: ignore[attr-defined]
    Ad, Bd, C, D = (np.asarray(v) for v in sys_.discretize(ctx.dt))
    D = float(D)
    Ai = Ad - np.outer(Bd, C) / D
    x0 = np.asarray(sys_.state0, dtype=np.float64)
    return _emit_state_space(Ai, Bd / D, -C / D, 1.0 / D, x0, ctx,
                             f"inverse linear system (ZOH, dt = {ctx.dt:g} s), order {Bd.size}",
                             "system.state0")


# ----------------------------------------------------------------------------- effects
def _first_sample(f: str, init: list[str]) -> list[str]:
    """Statements run once, at the first sample (models start "at rest at the first input")."""
    return [f"if (!st->{f}started) {{", *(f"    {line}" for line in init),
            f"    st->{f}started = 1;", "}"]


@register_c_stage(Resonance)
@register_c_stage(ResonanceInverse)
def _emit_foh_filter(model: Model, ctx: StageContext) -> CStage:
    """FOH-discretised transfer function, direct form II transposed (as ``lfilter``)."""

    assert ctx.dt is not None
    num, den = model._tf()  # type: ignore[attr-defined]
    b, a, zi = discretised_tf(num, den, ctx.dt)
    n, f, c = a.size - 1, ctx.field, ctx.const
    step = [
        *_first_sample(f, [f"for (i = 0; i < {n}u; ++i) st->{f}z[i] = {c}ZI[i] * x;"]),
        f"{{ const double y = {c}B[0] * x + st->{f}z[0];",
        f"  for (i = 0; i + 1 < {n}u; ++i) "
        f"st->{f}z[i] = {c}B[i + 1] * x + st->{f}z[i + 1] - {c}A[i + 1] * y;",
        f"  st->{f}z[{n - 1}] = {c}B[{n}] * x - {c}A[{n}] * y;",
        "  x = y; }",
    ]
    return CStage(
        title=f"{model.type_name} (FOH, dt = {ctx.dt:g} s), order {n}",
        fields=[f"double {f}z[{n}];", f"int {f}started;"],
        constants=[
            f"static const double {c}B[{n + 1}] = {_c_array(b)};",
            f"static const double {c}A[{n + 1}] = {_c_array(a)};",
            f"static const double {c}ZI[{n}] = {_c_array(zi)};",
        ],
        reset=[f"st->{f}started = 0;", f"for (i = 0; i < {n}u; ++i) st->{f}z[i] = 0.0;"],
        step=step,
        tune=_resonance_tune(model, n, c, ctx.dt),
        tune_helpers=_foh_helper(n, c),
    )


def _resonance_tune(model: Model, n: int, c: str, dt: float) -> list[str]:
    """``num``/``den`` of ``Resonance._tf`` / ``ResonanceInverse._tf`` from the fields, then
    the FOH discretisation (:func:`_foh_helper`)."""
    lines = [f"{{ double num[{n + 1}], den[{n + 1}];",
             "  const double w = 2.0 * 3.141592653589793 * $freq_hz[0];",
             "  const double z2w = 2.0 * $damping[0] * w;"]
    if isinstance(model, ResonanceInverse):
        lines += ["  const double wc = 2.0 * 3.141592653589793 * $bandwidth_hz[0];",
                  "  const double g = wc * wc / (w * w);",
                  "  num[0] = g * 3.0; num[1] = g * (wc + z2w * 3.0);",
                  "  num[2] = g * (z2w * wc + w * w * 3.0); num[3] = g * (w * w * wc);",
                  "  den[0] = 1.0; den[1] = 3.0 * wc; den[2] = 3.0 * wc * wc;",
                  "  den[3] = wc * wc * wc;"]
    else:
        lines += ["  num[0] = 0.0; num[1] = 0.0; num[2] = w * w;",
                  "  den[0] = 1.0; den[1] = z2w; den[2] = w * w;"]
    return [*lines, f"  {c}foh(num, den, {c_double(dt)}, {c}B, {c}A, {c}ZI); }}"]


def _foh_helper(n: int, c: str) -> list[str]:
    """C of ``{c}foh(num, den, dt, b, a, zi)``: the first-order-hold discretisation of the
    order-``n`` transfer function ``num(s)/den(s)`` (``num`` padded to ``n + 1``) as
    :func:`core.effects.discretised_tf`: the frequency is scaled to ``|den_n/den_0|^(1/n)``
    (a well-conditioned companion form), ``expm`` of the FOH block matrix (Taylor series
    with scaling and squaring), the discrete polynomials by Faddeev-LeVerrier and
    ``lfilter_zi`` by Gaussian elimination."""
    m = n + 2
    return [
        f"/* FOH discretisation of an order-{n} transfer function (see core/export_c.py) */",
        f"static void {c}charpoly(double A[{n}][{n}], double *p)",
        "{",
        f"    double Mk[{n}][{n}], T[{n}][{n}];",
        "    unsigned i, j, l, k;",
        "    memset(Mk, 0, sizeof Mk);",
        "    p[0] = 1.0;",
        f"    for (k = 1; k <= {n}u; ++k) {{",
        "        double tr = 0.0;",
        f"        for (i = 0; i < {n}u; ++i) for (j = 0; j < {n}u; ++j) {{",
        "            double s = i == j ? p[k - 1] : 0.0;",
        f"            for (l = 0; l < {n}u; ++l) s += A[i][l] * Mk[l][j];",
        "            T[i][j] = s;",
        "        }",
        "        memcpy(Mk, T, sizeof Mk);",
        f"        for (i = 0; i < {n}u; ++i)",
        f"            for (l = 0; l < {n}u; ++l) tr += A[i][l] * Mk[l][i];",
        "        p[k] = -tr / (double)k;",
        "    }",
        "}",
        f"static void {c}foh(const double *num, const double *den, double dt, double *b,",
        "                   double *a, double *zi)",
        "{",
        f"    double sc[{n + 1}], an[{n + 1}], bn[{n + 1}], C[{n}], w, D, Dd, nrm;",
        f"    double X[{m}][{m}], E[{m}][{m}], T[{m}][{m}], S[{m}][{m}];",
        f"    double Ad[{n}][{n}], Ab[{n}][{n}], Bd[{n}], q[{n}], G[{n}][{n + 1}];",
        "    unsigned i, j, l, k, s = 0u;",
        f"    w = pow(fabs(den[{n}] / den[0]), 1.0 / {n}.0);",
        f"    sc[{n}] = 1.0;",
        f"    for (i = {n}u; i > 0u; --i) sc[i - 1] = sc[i] * w;",
        f"    for (i = 0; i <= {n}u; ++i) {{",
        "        an[i] = den[i] / den[0] * sc[i] / sc[0];",
        "        bn[i] = num[i] / den[0] * sc[i] / sc[0];",
        "    }",
        "    dt *= w;",
        "    D = bn[0];",
        f"    for (i = 0; i < {n}u; ++i) C[i] = bn[i + 1] - an[i + 1] * D;",
        "    memset(X, 0, sizeof X);",
        f"    for (j = 0; j < {n}u; ++j) X[0][j] = -an[j + 1] * dt;",
        f"    for (i = 1; i < {n}u; ++i) X[i][i - 1] = dt;",
        f"    X[0][{n}] = dt;",
        f"    X[{n}][{n + 1}] = 1.0;",
        "    nrm = 0.0;",
        f"    for (i = 0; i < {m}u; ++i) {{",
        "        double r = 0.0;",
        f"        for (j = 0; j < {m}u; ++j) r += fabs(X[i][j]);",
        "        if (r > nrm) nrm = r;",
        "    }",
        "    while (nrm > 0.5) { nrm *= 0.5; ++s; }",
        f"    for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) {{",
        "        X[i][j] = ldexp(X[i][j], -(int)s);",
        "        E[i][j] = T[i][j] = i == j ? 1.0 : 0.0;",
        "    }",
        "    for (k = 1; k < 40u; ++k) { /* Taylor series of expm(X), |X| <= 1/2 */",
        f"        for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) {{",
        "            double v = 0.0;",
        f"            for (l = 0; l < {m}u; ++l) v += T[i][l] * X[l][j];",
        "            S[i][j] = v / (double)k;",
        "        }",
        "        memcpy(T, S, sizeof T);",
        f"        for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) E[i][j] += T[i][j];",
        "    }",
        "    for (k = 0; k < s; ++k) { /* squaring */",
        f"        for (i = 0; i < {m}u; ++i) for (j = 0; j < {m}u; ++j) {{",
        "            double v = 0.0;",
        f"            for (l = 0; l < {m}u; ++l) v += E[i][l] * E[l][j];",
        "            S[i][j] = v;",
        "        }",
        "        memcpy(E, S, sizeof E);",
        "    }",
        "    Dd = D;",
        f"    for (i = 0; i < {n}u; ++i) {{",
        f"        double v = E[i][{n}] - E[i][{n + 1}];",
        f"        for (j = 0; j < {n}u; ++j) {{",
        "            Ad[i][j] = E[i][j];",
        f"            v += E[i][j] * E[j][{n + 1}];",
        "        }",
        "        Bd[i] = v;",
        f"        Dd += C[i] * E[i][{n + 1}];",
        "    }",
        f"    for (i = 0; i < {n}u; ++i)",
        f"        for (j = 0; j < {n}u; ++j) Ab[i][j] = Ad[i][j] - Bd[i] * C[j];",
        f"    {c}charpoly(Ad, a);",
        f"    {c}charpoly(Ab, b);",
        f"    for (i = 0; i <= {n}u; ++i) b[i] += (Dd - 1.0) * a[i];",
        "    /* lfilter_zi: (I - companion(a)^T) zi = b[1:] - a[1:] b[0] */",
        f"    for (i = 0; i < {n}u; ++i) {{",
        f"        for (j = 0; j < {n}u; ++j) G[i][j] = i == j ? 1.0 : 0.0;",
        "        G[i][0] += a[i + 1];",
        f"        if (i + 1 < {n}u) G[i][i + 1] -= 1.0;",
        f"        G[i][{n}] = b[i + 1] - a[i + 1] * b[0];",
        "    }",
        f"    for (k = 0; k < {n}u; ++k) {{ /* elimination, partial pivoting */",
        "        unsigned p = k;",
        f"        for (i = k + 1; i < {n}u; ++i) if (fabs(G[i][k]) > fabs(G[p][k])) p = i;",
        f"        for (j = 0; j <= {n}u; ++j) {{",
        "            const double t = G[k][j];",
        "            G[k][j] = G[p][j];",
        "            G[p][j] = t;",
        "        }",
        f"        for (i = k + 1; i < {n}u; ++i) {{",
        "            const double f = G[i][k] / G[k][k];",
        f"            for (j = k; j <= {n}u; ++j) G[i][j] -= f * G[k][j];",
        "        }",
        "    }",
        f"    for (i = {n}u; i > 0u; --i) {{",
        f"        double v = G[i - 1][{n}];",
        f"        for (j = i; j < {n}u; ++j) v -= G[i - 1][j] * q[j];",
        "        q[i - 1] = v / G[i - 1][i - 1];",
        "    }",
        f"    for (i = 0; i < {n}u; ++i) zi[i] = q[i];",
        "}",
    ]


@register_c_stage(Lag)
@register_c_stage(Creep)
@register_c_stage(LagInverse)
@register_c_stage(CreepInverse)
def _emit_lag_bank(model: Model, ctx: StageContext) -> CStage:
    """Bank of first-order lags ``y = g0 x + sum c_j L_j[x]`` or its exact per-sample inverse."""

    assert ctx.dt is not None
    inverse = isinstance(model, LagInverse | CreepInverse)
    if isinstance(model, CreepInverse):
        bank = model.checked_bank(ctx.dt)
    elif isinstance(model, LagInverse):
        bank = Lag(model.tau_s).bank(ctx.dt)
    else:
        assert isinstance(model, Lag | Creep)
        bank = model.bank(ctx.dt)
    m, f, c = bank.c.size, ctx.field, ctx.const
    consts = [
        *([] if inverse else [f"static const double {c}G0 = {c_double(bank.g0)};"]),
        f"static const double {c}C[{m}] = {_c_array(bank.c)};",
        f"static const double {c}B0[{m}] = {_c_array(bank.b0)};",
        f"static const double {c}B1[{m}] = {_c_array(bank.b1)};",
        f"static const double {c}A1[{m}] = {_c_array(bank.a1)};",
        f"static const double {c}ZI[{m}] = {_c_array(bank.zi)};",
    ]
    init = [f"for (i = 0; i < {m}u; ++i) st->{f}s[i] = {c}ZI[i] * x;"]
    update = [
        f"for (i = 0; i < {m}u; ++i) {{",
        f"    const double l = {c}B0[i] * x + st->{f}s[i];",
        f"    st->{f}s[i] = {c}B1[i] * x - {c}A1[i] * l;",
    ]
    if inverse:
        consts.append(f"static const double {c}GAIN = {c_double(bank.gain0)};")
        step = [
            *_first_sample(f, init),
            "{ double acc = x;",
            f"  for (i = 0; i < {m}u; ++i) acc -= {c}C[i] * st->{f}s[i];",
            f"  x = acc / {c}GAIN; }}",
            *update, "}",
        ]
    else:
        step = [
            *_first_sample(f, init),
            f"{{ double acc = {c}G0 * x;",
            *(f"  {line}" for line in update),
            f"      acc += {c}C[i] * l;",
            "  }",
            "  x = acc; }",
        ]
    return CStage(
        title=f"{model.type_name}: {m} first-order lag(s) (FOH, dt = {ctx.dt:g} s)",
        fields=[f"double {f}s[{m}];", f"int {f}started;"],
        constants=consts,
        reset=[f"st->{f}started = 0;", f"for (i = 0; i < {m}u; ++i) st->{f}s[i] = 0.0;"],
        step=step,
        tune=_lag_bank_tune(model, m, c, ctx.dt, inverse),
    )


def _lag_bank_tune(model: Model, m: int, c: str, dt: float, inverse: bool) -> list[str]:
    """First-order FOH sections from the time constants (as ``LagBank.of``, closed form:
    ``p = exp(-dt/tau)``, ``q = tau/dt (1 - p)``, ``b0 = 1 - q``, ``b1 = q - p``)."""
    single = isinstance(model, Lag | LagInverse)
    tau, w = ("$tau_s[0]", "1.0") if single else ("$taus_s[i]", "$weights[i]")
    dts = c_double(dt)
    return [
        f"{{ double g0 = {'0.0' if single else '1.0'}, gain;",
        f"  for (i = 0; i < {m}u; ++i) {{",
        f"      const double p = exp(-{dts} / {tau});",
        f"      const double q = {tau} / {dts} * (1.0 - p);",
        f"      {c}C[i] = {w}; {c}B0[i] = 1.0 - q; {c}B1[i] = q - p; {c}A1[i] = -p;",
        f"      {c}ZI[i] = q;",
        *([] if single else [f"      g0 -= {c}C[i];"]),
        "  }",
        "  gain = g0;",
        f"  for (i = 0; i < {m}u; ++i) gain += {c}C[i] * {c}B0[i];",
        f"  {c}GAIN = gain; }}" if inverse else f"  {c}G0 = g0; (void)gain; }}",
    ]


@register_c_stage(Delay)
def _emit_delay(model: Model, ctx: StageContext) -> CStage:
    """Fractional delay ``m + f`` samples: ring buffer of the last ``m + 2`` inputs."""

    assert ctx.dt is not None
    m, frac = delay_split(model.delay_s, ctx.dt)  # type: ignore[attr-defined]
    size, f, c = m + 2, ctx.field, ctx.const
    return CStage(
        title=f"delay of {m} + {frac:.6g} sample(s) (dt = {ctx.dt:g} s)",
        fields=[f"double {f}h[{size}];", f"unsigned {f}pos;", f"int {f}started;"],
        constants=[f"static const double {c}F = {c_double(frac)};"],
        reset=[f"st->{f}started = 0;", f"st->{f}pos = 0u;",
               f"for (i = 0; i < {size}u; ++i) st->{f}h[i] = 0.0;"],
        step=[
            *_first_sample(f, [f"for (i = 0; i < {size}u; ++i) st->{f}h[i] = x;"]),
            f"st->{f}h[st->{f}pos] = x;",
            f"{{ const double newer = st->{f}h[(st->{f}pos + {size - m}u) % {size}u];",
            f"  const double older = st->{f}h[(st->{f}pos + {size - m - 1}u) % {size}u];",
            f"  st->{f}pos = (st->{f}pos + 1u) % {size}u;",
            f"  x = {c}F * older + (1.0 - {c}F) * newer; }}",
        ],
        tune=[  # as delay_split; the whole samples size the buffer: another count is refused
            f"{{ const double d = $delay_s[0] / {c_double(ctx.dt)};",
            "  const double m = floor(d + 1e-12);",
            f"  {c}F = m != {float(m)} ? NAN : d - m > 0.0 ? d - m : 0.0; }}",
        ],
    )


@register_c_stage(Advance)
def _emit_advance(model: Model, ctx: StageContext) -> CStage:
    """An advance only exists with preview: emitted through :func:`core.effects.causal_form`."""
    raise CExportError(
        "an 'advance' (inverse of a delay) needs the future; export the forward model's "
        "inverse (the compensator applies the preview: <name>_INV_PREVIEW)"
    )


@register_c_stage(Drift)
def _emit_drift(model: Model, ctx: StageContext) -> CStage:
    """Legendre drift in time ``x + sum a_k P_k(clamp(2 t / T - 1))``, ``t = start + k dt``."""
    assert ctx.dt is not None
    a = np.asarray(model.coefficients)  # type: ignore[attr-defined]
    n, f, c = a.size, ctx.field, ctx.const
    return CStage(
        title=f"drift, Legendre degree {n}",
        fields=[f"double {f}k;"],
        constants=[
            f"static const double {c}A[{n}] = {_c_array(a)};",
            f"static const double {c}T = {c_double(model.span_s)};",  # type: ignore[attr-defined]
            f"static const double {c}T0 = {c_double(model.start_s)};",  # type: ignore[attr-defined]
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


def _asym_consts(model: Model, c: str) -> list[str]:
    a = np.asarray(model.coefficients)  # type: ignore[attr-defined]
    return [
        f"static const double {c}A[{a.size}] = {_c_array(a)};",
        f"static const double {c}CTR = {c_double(model.center)};",  # type: ignore[attr-defined]
        f"static const double {c}S = {c_double(model.scale)};",  # type: ignore[attr-defined]
    ]


def _asym_helper(model: Model, c: str) -> list[str]:
    n = np.asarray(model.coefficients).size  # type: ignore[attr-defined]
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
def _emit_asymmetry(model: Model, ctx: StageContext) -> CStage:
    """Polynomial output map ``x + sum a_k ((x - c)/s)^k`` (Horner form)."""
    c = ctx.const
    n = np.asarray(model.coefficients).size  # type: ignore[attr-defined]
    return CStage(title="asymmetry output map", constants=_asym_consts(model, c),
                  helpers=_asym_helper(model, c), step=[f"x = {c}map(x);"],
                  tune=[f"for (i = 0; i < {n}u; ++i) {c}A[i] = $coefficients[i];",
                        f"{c}CTR = $center[0];", f"{c}S = $scale[0];"])


@register_c_stage(AsymmetryInverse)
def _emit_asymmetry_inverse(model: Model, ctx: StageContext) -> CStage:
    """Inverse output map: clip to the monotone range, bracket, 80 bisection steps.

    ``LOF``/``HIF`` say whether the range ends ``LO``/``HI`` are finite (else the bracket
    grows by doubling), so the same code serves a range retuned in the FMU."""

    lo, hi = model.forward.monotone_range()  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    n = np.asarray(model.coefficients).size  # type: ignore[attr-defined]
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


def _rate_parts(model: Model, ctx: StageContext) -> tuple[list[str], list[str], list[str]]:
    """Constants, reset and the helper ``eval(x, st)`` of a rate-dependent PI stage."""
    assert ctx.dt is not None
    n, f, c = model.thresholds.size, ctx.field, ctx.const  # type: ignore[attr-defined]
    consts = [
        f"static const double {c}P0 = {c_double(model.p0)};",  # type: ignore[attr-defined]
        f"static const double {c}R[{n}] = {_c_array(model.thresholds)};",  # type: ignore[attr-defined]
        f"static const double {c}W[{n}] = {_c_array(model.weights)};",  # type: ignore[attr-defined]
        f"static const double {c}Z0[{n}] = {_c_array(model.state0)};",  # type: ignore[attr-defined]
        f"static const double {c}K = {c_double(model.beta_s / ctx.dt)};",  # type: ignore[attr-defined]
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
def _emit_rate(model: Model, ctx: StageContext) -> CStage:
    """Rate-dependent PI: thresholds ``r_i + beta |x_k - x_(k-1)| / dt``."""
    f, c = ctx.field, ctx.const
    n = model.thresholds.size  # type: ignore[attr-defined]
    consts, reset, helper = _rate_parts(model, ctx)
    return CStage(
        title=f"rate-dependent PI, {n} play operator(s)",
        fields=[f"double {f}z[{n}];", f"double {f}up;", f"int {f}has_prev;"],
        constants=consts, reset=reset, helpers=helper,
        tune=_rate_tune(n, c, ctx.dt),  # type: ignore[arg-type]
        step=["{ const double xin = x;",
              f"  x = {c}eval(xin, st->{f}z, st->{f}up, st->{f}has_prev, st->{f}z);",
              f"  st->{f}up = xin;",
              f"  st->{f}has_prev = 1; }}"],
        needs_math=True,
    )


def _rate_bisection_step(f: str, c: str) -> list[str]:
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
def _emit_rate_inverse(model: Model, ctx: StageContext) -> CStage:
    """Per-sample bisection of the rate-dependent PI (as ``RateDependentPIInverse``)."""
    assert ctx.dt is not None
    m_lo, m_hi = model.checked_slopes(ctx.dt)  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    n = model.thresholds.size  # type: ignore[attr-defined]
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
        step=_rate_bisection_step(f, c),
        needs_math=True,
    )


def _preisach_parts(model: Model, ctx: StageContext,
                    rate: bool = False) -> tuple[list[str], list[str], list[str]]:
    """Constants, reset and helpers (``level``, ``eval``) of a Preisach play bank; with
    ``rate`` (a :class:`RateDependentPreisach`), ``eval(x, zin, up, has_prev, zout)`` with
    the thresholds ``r_i + K |x - up|`` of the plays with ``r_i > 0``."""
    n, m = model.n, model.n_segments  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    consts = [
        f"static const double {c}R[{n}] = {_c_array(model.thresholds)};",  # type: ignore[attr-defined]
        f"static const double {c}W[{n * m}] = {_c_array(model.weights)};",  # type: ignore[attr-defined]
        f"static const double {c}Z0[{n}] = {_c_array(model.state0)};",  # type: ignore[attr-defined]
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
        consts.append(f"static const double {c}E[{m - 1}] = {_c_array(model.knots)};")  # type: ignore[attr-defined]
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
    assert ctx.dt is not None
    consts.append(f"static const double {c}K = {c_double(model.beta_s / ctx.dt)};")  # type: ignore[attr-defined]
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


def _preisach_tune(model: Model, c: str, pre: str) -> list[str]:
    """Tune lines of a Preisach bank whose fields are ``$<pre>thresholds`` etc."""
    n, m = model.n, model.n_segments  # type: ignore[attr-defined]
    return [
        f"for (i = 0; i < {n}u; ++i) {{",
        f"    {c}R[i] = ${pre}thresholds[i]; {c}Z0[i] = ${pre}state0[i];",
        "}",
        f"for (i = 0; i < {n * m}u; ++i) {c}W[i] = ${pre}weights[i];",
        *([f"for (i = 0; i < {m - 1}u; ++i) {c}E[i] = ${pre}knots[i];"] if m > 1 else []),
    ]


@register_c_stage(PreisachModel)
def _emit_preisach(model: Model, ctx: StageContext) -> CStage:
    """Preisach play bank ``x <- sum_i sum_j W[i][j] seg_j(z_i)`` (as ``preisach_output``)."""
    n, m = model.n, model.n_segments  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    consts, reset, helpers = _preisach_parts(model, ctx)
    return CStage(
        title=f"Preisach model, {n} play operator(s) x {m} level segment(s)",
        fields=[f"double {f}z[{n}];"], constants=consts, reset=reset, helpers=helpers,
        step=[f"x = {c}eval(x, st->{f}z, st->{f}z);"],
        tune=_preisach_tune(model, c, ""),
    )


@register_c_stage(PreisachInverse)
def _emit_preisach_inverse(model: Model, ctx: StageContext) -> CStage:
    """Exact per-sample inverse of the Preisach model (as ``core.kernels.preisach_inverse``)."""
    fwd = model.model  # type: ignore[attr-defined]
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


def _bouc_wen_parts(
    model: Model, ctx: StageContext, solve: bool
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
        f"static const double {c}C[{m}] = {_c_array(model.weights)};",
        f"static const double {c}B[{m}] = {_c_array(model.beta)};",
        f"static const double {c}G[{m}] = {_c_array(model.gamma)};",
        f"static const double {c}N[{m}] = {_c_array(model.exponent)};",
        f"static const double {c}L[{m}] = "
        f"{_c_array(saturation_levels(model.beta, model.gamma, model.exponent))};",
        f"static const double {c}Z0[{m}] = {_c_array(model.state0)};",
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
def _emit_bouc_wen(model: Model, ctx: StageContext) -> CStage:
    """Bouc-Wen bank ``x <- k x + sum_j c_j z_j`` (as ``core.kernels.bouc_wen_output``)."""
    f, c = ctx.field, ctx.const
    m = model.n  # type: ignore[attr-defined]
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
def _emit_bouc_wen_inverse(model: Model, ctx: StageContext) -> CStage:
    """Per-sample solve of the Bouc-Wen model (as ``core.kernels.bouc_wen_inverse``)."""
    fwd = model.model  # type: ignore[attr-defined]
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
def _emit_rate_preisach(model: Model, ctx: StageContext) -> CStage:
    """Rate-dependent Preisach bank (as ``RateDependentPreisach``)."""
    assert ctx.dt is not None
    n, m = model.n, model.n_segments  # type: ignore[attr-defined]
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
def _emit_rate_preisach_inverse(model: Model, ctx: StageContext) -> CStage:
    """Per-sample bisection of the rate-dependent Preisach (as
    ``RateDependentPreisachInverse``)."""
    assert ctx.dt is not None
    m_lo, m_hi = model.checked_slopes(ctx.dt)  # type: ignore[attr-defined]
    fwd = model.model  # type: ignore[attr-defined]
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
        step=_rate_bisection_step(f, c),
        needs_math=True,
    )


# ----------------------------------------------------------------------------- generation
def _flatten(model: Model) -> list[Model]:
    """Stages in application order: chains and cascades (``as_chain()``) are expanded."""
    if isinstance(model, Chain):
        out: list[Model] = []
        for s in model.stages:
            out.extend(_flatten(s))
        return out
    as_chain = getattr(model, "as_chain", None)
    if callable(as_chain):
        return _flatten(as_chain())
    return [model]


def _has_advance(model: Model) -> bool:
    return any(isinstance(s, Advance) for s in _flatten(model))


def _check_ident(name: str) -> str:
    if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name) or name in _C_KEYWORDS:
        raise CExportError(
            f"C name {name!r} is not a valid C identifier; use letters, digits and underscores, "
            "not starting with a digit (e.g. 'piezo_comp')"
        )
    return name


def c_identifier(text: str) -> str:
    """Turn a file stem such as ``"my-comp.v2"`` into a C identifier (``"my_comp_v2"``)."""
    s = re.sub(r"[^A-Za-z0-9_]", "_", text) or "hyst"
    if s[0].isdigit() or s in _C_KEYWORDS:
        s = "h_" + s
    return s


def _type_of(m: Model) -> str:
    return type(m).type_name


def emit_stages(
    model: Model, name: str, dt: float | None, what: str
) -> tuple[list[Model], list[CStage]]:
    """The flattened stages of ``model`` and their C fragments for block ``name``.

    Raises
    ------
    CExportError
        A dynamic stage without ``dt``, or a stage type without an emitter.
    """
    stages = _flatten(model)
    if any(s.needs_dt for s in stages) and (dt is None or not dt > 0):
        raise CExportError(
            f"the {what} has dynamics (needs_dt); give the sample time, e.g. dt=1e-4 "
            "(--dt on the command line)"
        )
    emitted: list[CStage] = []
    for k, s in enumerate(stages):
        t = _type_of(s)
        emitter = emitter_for(s)
        if emitter is None:
            raise CExportError(
                f"C export of model type {t!r} (stage {k} of the {what}) is not supported; "
                f"supported stage types: {', '.join(supported_c_types())}"
            )
        emitted.append(emitter(s, StageContext(f"s{k}_", f"{name}_s{k}_", dt)))
    return stages, emitted


_CONST = re.compile(r"static const ([a-z ]+?) (\w+)(?:\[(\d+)\])? = (.*);", re.DOTALL)


def parse_constant(decl: str) -> tuple[str, str, int | None, str]:
    """``(C type, identifier, array size or None, initialiser)`` of a stage constant
    (one ``static const <type> <ident>[<n>] = <init>;`` item of :attr:`CStage.constants`)."""
    m = _CONST.fullmatch(decl.strip())
    if m is None:  # pragma: no cover - every emitter writes this form
        raise CExportError(f"not a stage constant definition: {decl[:60]!r}")
    return m.group(1), m.group(2), None if m.group(3) is None else int(m.group(3)), m.group(4)


def _emit_block(
    model: Model, name: str, dt: float | None, what: str, params: str | None = None,
    emitted: list[CStage] | None = None,
) -> tuple[str, str, bool]:
    """(header part, source part, needs <math.h>) of one block ``name`` implementing ``model``.

    With ``params`` (a C expression of a pointer to a struct holding every stage constant
    under its own name), the constants are not defined here but read through that pointer
    (``#define <ident> (<params>-><ident>)``): the run-time tunable form of the FMU.
    ``emitted``: the fragments of :func:`emit_stages` when the caller has them already.
    """
    stages = _flatten(model)
    if emitted is None:
        stages, emitted = emit_stages(model, name, dt, what)
    fields = [f for st in emitted for f in st.fields] or ["int unused_; /* stateless */"]
    h: list[str] = []
    h.append(f"/* {what}: {len(stages)} stage(s): "
             + " -> ".join(_type_of(s) for s in stages) + " */")
    h.append("typedef struct {")
    h.extend(f"    {f}" for f in fields)
    h.append(f"}} {name}_state;")
    h.append("")
    h.append(f"/** Initialise the state before first use (same as {name}_reset). */")
    h.append(f"void {name}_init({name}_state *st);")
    h.append("/** Return the state to the model's initial state (state0). */")
    h.append(f"void {name}_reset({name}_state *st);")
    h.append("/** Process one sample: returns the output for input u. */")
    h.append(f"double {name}_step({name}_state *st, double u);")
    h.append(f"/** Process n samples: y[k] = {name}_step(st, u[k]); y may alias u. */")
    h.append(f"void {name}_run({name}_state *st, const double *u, double *y, size_t n);")

    src: list[str] = [f"/* ---- {what} ---- */"]
    for k, st in enumerate(emitted):
        src.append(f"/* stage {k}: {st.title} */")
        if params is None:
            src.extend(st.constants)
        else:
            for decl in st.constants:
                ident = parse_constant(decl)[1]
                src.append(f"#define {ident} ({params}->{ident})")
        src.extend(st.helpers)
    uses_i_reset = any("for (i" in line for st in emitted for line in st.reset)
    uses_i_step = any("for (i" in line for st in emitted for line in st.step)
    src.append("")
    src.append(f"void {name}_reset({name}_state *st)")
    src.append("{")
    if uses_i_reset:
        src.append("    unsigned i;")
    body = [line for st in emitted for line in st.reset]
    if not body:
        src.append("    st->unused_ = 0;")
    src.extend(f"    {line}" for line in body)
    src.append("}")
    src.append("")
    src.append(f"void {name}_init({name}_state *st)")
    src.append("{")
    src.append(f"    {name}_reset(st);")
    src.append("}")
    src.append("")
    src.append(f"double {name}_step({name}_state *st, double u)")
    src.append("{")
    src.append("    double x = u;")
    if uses_i_step:
        src.append("    unsigned i;")
    src.append("    (void)st;")
    for k, st in enumerate(emitted):
        src.append(f"    {{ /* stage {k}: {st.title} */")
        src.extend(f"        {line}" for line in st.step)
        src.append("    }")
    src.append("    return x;")
    src.append("}")
    src.append("")
    src.append(f"void {name}_run({name}_state *st, const double *u, double *y, size_t n)")
    src.append("{")
    src.append("    size_t k;")
    src.append("    for (k = 0; k < n; ++k) {")
    src.append(f"        y[k] = {name}_step(st, u[k]);")
    src.append("    }")
    src.append("}")
    return "\n".join(h), "\n".join(src), any(st.needs_math for st in emitted)


@dataclass(frozen=True)
class CCode:
    """Generated C99 code.

    Attributes
    ----------
    name : str
        Prefix of every public identifier (``<name>_inv_step``, ...) and the file stem.
    header : str
        Contents of ``<name>.h``.
    source : str
        Contents of ``<name>.c`` (it includes ``"<name>.h"``).
    blocks : tuple of str
        Generated block names, e.g. ``("hyst_inv", "hyst_fwd")``.
    """

    name: str
    header: str
    source: str
    blocks: tuple[str, ...]

    def write(self, directory: str | Path) -> tuple[Path, Path]:
        """Write ``<name>.h`` and ``<name>.c`` into ``directory`` (created if needed).

        Returns
        -------
        (Path, Path)
            Header and source paths.
        """
        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        h = d / f"{self.name}.h"
        c = d / f"{self.name}.c"
        h.write_text(self.header, encoding="utf-8")
        c.write_text(self.source, encoding="utf-8")
        return h, c


def causal_compensator(model: Model, dt: float | None) -> tuple[Model, int]:
    """``model.inverse()`` in the causal form a real-time compensator runs, and its preview.

    An inverse that holds an advance (the inverse of a delay) needs the future: it becomes
    :func:`core.effects.causal_form`, fed the desired output ``preview`` samples ahead.

    Raises
    ------
    CExportError
        If the inverse holds an advance and ``dt`` is missing.
    NotInvertibleError
        If the model has no inverse.
    """
    inv = model.inverse()
    if not _has_advance(inv):
        return inv, 0
    if dt is None or not dt > 0:
        raise CExportError(
            "the compensator inverts a delay and needs the sample time to size its "
            "preview; give dt (--dt on the command line)"
        )
    from .effects import causal_form

    form = causal_form(inv, dt)
    return form.model, form.preview


def generate_c(
    model: Model | ParameterSet,
    name: str = "hyst",
    *,
    inverse: bool = True,
    forward: bool = True,
    dt: float | None = None,
    description: str | None = None,
) -> CCode:
    """Generate C99 code for a model's inverse compensator and/or the model itself.

    Parameters
    ----------
    model : Model or ParameterSet
        The (forward) hysteresis model. Its inverse is computed with ``model.inverse()``.
    name : str
        C identifier used as prefix and file stem (default ``"hyst"``).
    inverse : bool
        Emit the compensator ``<name>_inv_*`` (requires an invertible model).
    forward : bool
        Emit the forward model ``<name>_fwd_*``.
    dt : float, optional
        Sample time in seconds, baked into dynamic stages (required when a stage has
        ``needs_dt``).
    description : str, optional
        Free text put in the header comment (e.g. the provenance source).

    Returns
    -------
    CCode

    Raises
    ------
    CExportError
        Bad name, nothing to emit, or a stage type without a C emitter.
    NotInvertibleError
        ``inverse=True`` and the model has no inverse.
    """
    from .paramset import ParameterSet

    units = None
    doc = None
    if isinstance(model, ParameterSet):
        units = model.units
        description = description or model.provenance.source
        doc = model.to_dict()["model"]
        model = model.model
    if not isinstance(model, Model):
        raise CExportError(f"generate_c needs a Model or ParameterSet, got {type(model).__name__}")
    _check_ident(name)
    if not (inverse or forward):
        raise CExportError("nothing to generate: pass inverse=True and/or forward=True")
    blocks: list[tuple[str, Model, str]] = []
    preview = 0
    if inverse:
        inv, preview = causal_compensator(model, dt)
        blocks.append((f"{name}_inv", inv, "inverse compensator"))
    if forward:
        blocks.append((f"{name}_fwd", model, "forward model"))

    import json

    guard = f"{name.upper()}_H_INCLUDED"
    info = [
        f"Generated by {_tool()} (core/export_c.py). C99, no allocation.",
    ]
    if description:
        info.append(f"Source: {c_comment(description)}")
    if units is not None:
        u_in, u_out = c_comment(units.input), c_comment(units.output)
        info.append(f"Units: forward model {u_in} -> {u_out}; compensator {u_out} -> {u_in}.")
    if dt is not None:
        info.append(f"Sample time baked in: dt = {c_double(dt)} s.")
    info.append("Forward model parameters (JSON):")
    # sanitised before wrapping: wrapping only breaks at spaces of the sanitised text
    model_json = c_comment(json.dumps(doc if doc is not None else model.to_dict(),
                                      ensure_ascii=False))
    info.extend(
        "  " + line
        for line in textwrap.wrap(model_json, 90, break_long_words=False, break_on_hyphens=False)
    )
    usage = [
        "Usage (compensator before the actuator):",
        f"  {name}_inv_state st; {name}_inv_init(&st);",
        f"  each sample: drive = {name}_inv_step(&st, desired_output);",
        *([f"PREVIEW: the model has a delay; feed the desired output {preview} sample(s)",
           f"  ahead ({name.upper()}_INV_PREVIEW): step k takes desired[k + {preview}] and",
           "  returns the drive for sample k (the first calls are warm-up)."] if preview else []),
    ] if inverse else []
    header_lines = ["/*"] + [f" * {line}".rstrip() for line in info + [""] + usage] + [" */"]
    header_lines += [f"#ifndef {guard}", f"#define {guard}", "", "#include <stddef.h>", ""]
    header_lines += ["#ifdef __cplusplus", 'extern "C" {', "#endif", ""]
    if inverse:
        header_lines += [
            "/** Samples of the desired trajectory the compensator needs ahead (0: none). */",
            f"#define {name.upper()}_INV_PREVIEW {preview}",
            "",
        ]
    parts = [_emit_block(bmodel, bname, dt, what) for bname, bmodel, what in blocks]
    source_lines = [
        f"/* {name}.c: generated by {_tool()}; see {name}.h. */",
        f'#include "{name}.h"',
        *(["#include <math.h>"] if any(p[2] for p in parts) else []),
        "",
    ]
    for h, s, _ in parts:
        header_lines += [h, ""]
        source_lines += [s, ""]
    header_lines += ["#ifdef __cplusplus", "}", "#endif", "", f"#endif /* {guard} */", ""]
    return CCode(
        name=name,
        header="\n".join(header_lines),
        source="\n".join(source_lines),
        blocks=tuple(b[0] for b in blocks),
    )


def _tool() -> str:
    from .paramset import tool_name

    return tool_name()


def export_c(
    model: Model | ParameterSet,
    path: str | Path,
    *,
    name: str | None = None,
    inverse: bool = True,
    forward: bool = True,
    dt: float | None = None,
) -> tuple[Path, Path]:
    """Write ``<stem>.h`` and ``<stem>.c`` next to ``path``.

    Parameters
    ----------
    model : Model or ParameterSet
    path : str or Path
        ``dir/stem.c``, ``dir/stem.h`` or ``dir/stem``; both files are written into ``dir``.
    name : str, optional
        C prefix; defaults to the stem made into a C identifier.
    inverse, forward, dt
        See :func:`generate_c`.

    Returns
    -------
    (Path, Path)
        Header and source paths.
    """
    p = Path(path)
    stem = p.stem if p.suffix in (".c", ".h") else p.name
    code = generate_c(
        model, name or c_identifier(stem), inverse=inverse, forward=forward, dt=dt
    )
    d = p.parent
    d.mkdir(parents=True, exist_ok=True)
    h = d / f"{stem}.h"
    c = d / f"{stem}.c"
    h.write_text(code.header, encoding="utf-8")
    c.write_text(code.source.replace(f'#include "{code.name}.h"', f'#include "{stem}.h"'),
                 encoding="utf-8")
    return h, c


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
            f"static const double {c}R[{n}] = {_c_array(model.thresholds)};",
            f"static const double {c}W[{n}] = {_c_array(model.weights)};",
            f"static const double {c}Z0[{n}] = {_c_array(model.state0)};",
            f"static const double {c}V0 = {c_double(float(np.mean(model.state0)))};",
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
def _emit_stop_gap_inverse(model: Model, ctx: StageContext) -> CStage:
    """The element bank's play-type PI inverse plus the gap side ``(b/2) sign(y)`` (held at
    ``y = 0``)."""
    assert isinstance(model, StopGapInverse)
    stage = _emit_pi(model.model, ctx)
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
def _emit_stop_pi(model: Model, ctx: StageContext) -> CStage:
    """Stop-operator bank (Maxwell-slip) as its play-type PI, ``p0 = k + sum w_i`` and
    ``p_i = -w_i`` (``x - z_i`` is stop ``i``'s output): the PI's stage, with constants
    tuned from the stop fields."""

    assert isinstance(model, StopPIModel)
    if model.gap > 0:
        return _emit_stop_gap(model, ctx)
    stage = _emit_pi(model.equivalent_pi(), ctx)
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
