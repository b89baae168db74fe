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
from .exceptions import ParameterError

if TYPE_CHECKING:
    from .paramset import ParameterSet

__all__ = [
    "CCode",
    "CExportError",
    "CStage",
    "StageContext",
    "c_identifier",
    "c_double",
    "export_c",
    "generate_c",
    "register_c_stage",
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
    """

    title: str
    fields: list[str] = field(default_factory=list)
    constants: list[str] = field(default_factory=list)
    reset: list[str] = field(default_factory=list)
    step: list[str] = field(default_factory=list)
    helpers: list[str] = field(default_factory=list)
    needs_math: bool = False


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
_EMITTERS: dict[str, Emitter] = {}


def register_c_stage(type_name: str) -> Callable[[Emitter], Emitter]:
    """Decorator registering the C emitter of a model ``type`` (see :class:`CStage`)."""

    def deco(fn: Emitter) -> Emitter:
        _EMITTERS[type_name] = fn
        return fn

    return deco


def supported_c_types() -> list[str]:
    """Model types that :func:`generate_c` can emit (``chain`` of these included)."""
    return sorted(_EMITTERS)


# ----------------------------------------------------------------------------- stage emitters
@register_c_stage("pi")
def _emit_pi(model: Model, ctx: StageContext) -> CStage:
    """Play-operator bank ``x <- p0 x + sum_i w_i z_i`` with ``z_i = clamp(z_i, x-r_i, x+r_i)``."""
    from .pi import PIModel

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
    )


@register_c_stage("offset")
def _emit_offset(model: Model, ctx: StageContext) -> CStage:
    """Constant output offset ``x <- x + c``."""
    c = float(model.offset)  # type: ignore[attr-defined]
    return CStage(
        title="output offset",
        constants=[f"static const double {ctx.const}C = {c_double(c)};"],
        step=[f"x = x + {ctx.const}C;"],
    )


@register_c_stage("deadzone")
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
    )


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


def _direction_state(model: Model, f: str) -> tuple[list[str], list[str]]:
    d0 = int(model.direction0)  # type: ignore[attr-defined]
    return (
        [f"double {f}prev;", f"int {f}has_prev;", f"int {f}dir;"],
        [f"st->{f}prev = 0.0;", f"st->{f}has_prev = 0;", f"st->{f}dir = {d0};"],
    )


@register_c_stage("tanh-envelope")
def _emit_tanh(model: Model, ctx: StageContext) -> CStage:
    """Direction-switching envelope ``c0 tanh(c1 x + c2) + c3`` (a while rising, b falling)."""
    a = np.asarray(model.a)  # type: ignore[attr-defined]
    b = np.asarray(model.b)  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    fields, reset = _direction_state(model, f)
    return CStage(
        title="tanh envelope (kappa_R rising, kappa_L falling)",
        fields=fields,
        constants=[
            f"static const double {c}A[4] = {_c_array(a)};",
            f"static const double {c}B[4] = {_c_array(b)};",
        ],
        reset=reset,
        step=[
            *_direction_step(f),
            f"{{ const double *k = st->{f}dir > 0 ? {c}A : {c}B;",
            "  x = k[0] * tanh(k[1] * x + k[2]) + k[3]; }",
        ],
        needs_math=True,
    )


@register_c_stage("tanh-envelope-inverse")
def _emit_tanh_inverse(model: Model, ctx: StageContext) -> CStage:
    """Inverse envelope ``(atanh((x - c3)/c0) - c2)/c1``, clipped to its domain.

    Samples outside ``|x - c3| < (1 - clip_margin)|c0|`` are clipped like the Python model;
    ``st->{field}clipped`` counts them (the Python model warns instead).
    """
    a = np.asarray(model.a)  # type: ignore[attr-defined]
    b = np.asarray(model.b)  # type: ignore[attr-defined]
    lim = 1.0 - float(model.clip_margin)  # type: ignore[attr-defined]
    f, c = ctx.field, ctx.const
    fields, reset = _direction_state(model, f)
    return CStage(
        title="inverse tanh envelope (clips to its domain, counts clipped samples)",
        fields=[*fields, f"unsigned long {f}clipped;"],
        constants=[
            f"static const double {c}A[4] = {_c_array(a)};",
            f"static const double {c}B[4] = {_c_array(b)};",
            f"static const double {c}LIM = {c_double(lim)};",
        ],
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


@register_c_stage("digitized")
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


@register_c_stage("digitized-deadzone")
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
        ],
        reset=[f"st->{f}seg = {c0}u;"],
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
    ctx: StageContext, title: str,
) -> CStage:
    """``y = C x + D u``, ``x+ = Ad x + Bd u`` (the update order of ``core.lti.lti_run``)."""
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
    )


@register_c_stage("lti")
def _emit_lti(model: Model, ctx: StageContext) -> CStage:
    """Linear system, exact ZOH at the ``dt`` given to :func:`generate_c`."""
    assert ctx.dt is not None
    Ad, Bd, C, D = model.discretize(ctx.dt)  # type: ignore[attr-defined]
    x0 = np.asarray(model.state0, dtype=np.float64)  # type: ignore[attr-defined]
    return _emit_state_space(np.asarray(Ad), np.asarray(Bd), np.asarray(C), float(D), x0, ctx,
                             f"linear system (ZOH, dt = {ctx.dt:g} s), order {Bd.size}")


@register_c_stage("lti_inverse")
def _emit_lti_inverse(model: Model, ctx: StageContext) -> CStage:
    """Sampled inverse of a biproper linear system (carries the forward state)."""
    assert ctx.dt is not None
    sys_ = model.system  # type: ignore[attr-defined]
    Ad, Bd, C, D = (np.asarray(v) for v in sys_.discretize(ctx.dt))
    D = float(D)
    Ai = Ad - np.outer(Bd, C) / D
    x0 = np.asarray(sys_.state0, dtype=np.float64)
    return _emit_state_space(Ai, Bd / D, -C / D, 1.0 / D, x0, ctx,
                             f"inverse linear system (ZOH, dt = {ctx.dt:g} s), order {Bd.size}")


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


def _emit_block(
    model: Model, name: str, dt: float | None, what: str
) -> tuple[str, str, bool]:
    """(header part, source part, needs <math.h>) of one block ``name`` implementing ``model``."""
    stages = _flatten(model)
    if any(s.needs_dt for s in stages) and (dt is None or not dt > 0):
        raise CExportError(
            f"the {what} has dynamics (needs_dt); give the sample time, e.g. dt=1e-4 "
            "(--dt on the command line)"
        )
    emitted: list[CStage] = []
    for k, s in enumerate(stages):
        t = _type_of(s)
        emitter = _EMITTERS.get(t)
        if emitter is None:
            raise CExportError(
                f"C export of model type {t!r} (stage {k} of the {what}) is not supported; "
                f"supported stage types: {', '.join(supported_c_types())}"
            )
        emitted.append(emitter(s, StageContext(f"s{k}_", f"{name}_s{k}_", dt)))

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
        src.extend(st.constants)
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
    if not any(st.step for st in emitted) or not any(st.fields for st in emitted):
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


def _comment_safe(text: str) -> str:
    return text.replace("*/", "* /").replace("/*", "/ *")


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
    if inverse:
        blocks.append((f"{name}_inv", model.inverse(), "inverse compensator"))
    if forward:
        blocks.append((f"{name}_fwd", model, "forward model"))

    import json

    guard = f"{name.upper()}_H_INCLUDED"
    info = [
        f"Generated by {_tool()} (core/export_c.py). C99, no allocation.",
    ]
    if description:
        info.append(f"Source: {_comment_safe(description)}")
    if units is not None:
        info.append(
            f"Units: forward model {units.input} -> {units.output}; "
            f"compensator {units.output} -> {units.input}."
        )
    if dt is not None:
        info.append(f"Sample time baked in: dt = {c_double(dt)} s.")
    info.append("Forward model parameters (JSON):")
    model_json = json.dumps(doc if doc is not None else model.to_dict())
    info.extend(
        "  " + _comment_safe(line)
        for line in textwrap.wrap(model_json, 90, break_long_words=False, break_on_hyphens=False)
    )
    usage = [
        "Usage (compensator before the actuator):",
        f"  {name}_inv_state st; {name}_inv_init(&st);",
        f"  each sample: drive = {name}_inv_step(&st, desired_output);",
    ] if inverse else []
    header_lines = ["/*"] + [f" * {line}".rstrip() for line in info + [""] + usage] + [" */"]
    header_lines += [f"#ifndef {guard}", f"#define {guard}", "", "#include <stddef.h>", ""]
    header_lines += ["#ifdef __cplusplus", 'extern "C" {', "#endif", ""]
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

