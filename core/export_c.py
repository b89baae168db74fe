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
and step statements through an emitter registered with :func:`register_c_stage` (one module
per model family in :mod:`core.c_emit`), so new model types plug in without touching the rest.
Stage types with an emitter: see :func:`supported_c_types`.
"""

from __future__ import annotations

import re
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from . import c_emit  # noqa: F401  (registers every model family's emitter)
from .base import Chain, Model
from .c_emit.stage import (
    CExportError,
    CStage,
    StageContext,
    c_double,
    emitter_for,
    register_c_stage,
    supported_c_types,
)
from .escape import c_comment
from .stages import Advance

if TYPE_CHECKING:
    from .paramset import ParameterSet, Units

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
    :func:`core.stages.causal_form`, fed the desired output ``preview`` samples ahead.

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
    from .stages import causal_form

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

    guard = f"{name.upper()}_H_INCLUDED"
    comment = _header_comment(name, model, doc, description, units, dt,
                              preview if inverse else None)
    header_lines = ["/*"] + [f" * {line}".rstrip() for line in comment] + [" */"]
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


def _header_comment(name: str, model: Model, doc: object, description: str | None,
                    units: Units | None, dt: float | None, preview: int | None) -> list[str]:
    """The lines of the header's opening comment: the tool, the source, the units, the baked
    sample time, the forward model's parameters (JSON) and, with a compensator
    (``preview`` its samples ahead; ``None`` without one), how to use it."""
    import json

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
    ] if preview is not None else []
    return info + [""] + usage


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
