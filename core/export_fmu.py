"""FMU export: a native-C co-simulation Functional Mock-up Unit (FMI 3.0 or 2.0).

The FMU runs the C99 code of :mod:`core.export_c` (the model, or its inverse compensator in
the causal form with its preview) behind the FMI co-simulation API, compiled on this machine
(``binaries/x86_64-linux`` for FMI 3, ``binaries/linux64`` for FMI 2) and shipped with its
source (``sources/``) so another platform can rebuild it. Its ports and parameters:

- one input and one output (``u`` -> ``y`` for the model, ``y_ref`` -> ``u`` for the
  compensator), with the units of the parameter set;
- every model parameter of every stage as a scalar variable named
  ``<stage>.<field>[i]`` (``pi.weights[3]``, ``s1_creep.taus_s[2]``) with its value, unit
  and description: ``tunable`` where the stage's C emitter says how its constants follow
  from it (:attr:`core.export_c.CStage.tune`), ``fixed`` for the initial memory state
  (``state0``, ``direction0``: set before initialisation; the exported value is the model's,
  a virgin state unless the model says otherwise), and a ``constant`` where the stage has no
  tune lines (today the LTI coefficients, whose balanced realisation is computed at export:
  re-export to change them); a value whose derived constants are not finite is refused;
- ``sample_time`` (``dt``: a fixed parameter whose only allowed value is the exported one)
  and ``preview_samples`` (a calculated parameter: the compensator's preview,
  :func:`core.stages.causal_form`; also stated in the model description);
- ``min`` / ``max`` from the hard limits the model's fields declare, checked in C when a
  value is set (with the order of increasing fields), units in the ASCII spelling FMI tools
  parse with their SI base units (:func:`fmi_unit`, :func:`base_unit`).

Bad values are refused and leave the FMU as it was (NaN or infinite input, a value breaking
a field's rule, a step whose output would not be finite: ``Discard``).

Stepping: the FMU counts its own samples. One ``doStep`` of size ``h`` runs, with the input
held, the samples whose instants (multiples of ``dt`` from the start) it reaches, and holds
the part of a sample left over for the next step; a step that ends within 1e-6 of a sample of
an instant ends on it, so an importer's floating-point time (``t += dt``, a tiny last step to
the stop time) never runs a sample twice or skips one. Without dynamics (no ``dt``) one
``doStep`` of positive length is one sample. The output after a step is the model's output
at the last sample run, so feeding ``u[k]`` and stepping ``dt`` reproduces
``model.simulate(u)[k]``.

The C file around the model block (instance, FMI functions) is :mod:`core.fmi_c`. The FMI
headers are not part of this repository: they come with ``fmpy`` (its ``c-code`` folder),
found at build time (:func:`fmi_headers`).
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .base import Field, Model
from .escape import xml_attr
from .export_c import (
    CExportError,
    _emit_block,
    c_double,
    c_identifier,
    causal_compensator,
    emit_stages,
    parse_constant,
)
from .fmi_c import FmuCode, fmu_c_source
from .validation import filled

if TYPE_CHECKING:
    from .paramset import ParameterSet, Units

__all__ = [
    "FMI_VERSIONS",
    "FmuExportError",
    "FmuSources",
    "FmuVariable",
    "base_unit",
    "build_fmu",
    "find_compiler",
    "fmi_headers",
    "fmi_unit",
    "fmu_sources",
]

#: FMI versions an FMU can be built for.
FMI_VERSIONS = (3, 2)
#: Value reference of the first model parameter (0..99: time, ports, constants).
FIRST_PARAMETER_VR = 100
_STATE_FIELDS = ("state0", "direction0")


class FmuExportError(CExportError):
    """The FMU cannot be built (bad options, no C compiler, no FMI headers, build failed)."""


@dataclass(frozen=True)
class FmuVariable:
    """One scalar variable of the FMU's ``modelDescription.xml``.

    Attributes
    ----------
    name : str
        Structured name (``u``, ``pi.weights[2]``).
    vr : int
        Value reference.
    causality : str
        ``independent``, ``input``, ``output``, ``parameter`` or ``local``.
    variability : str
        ``continuous``, ``discrete``, ``tunable``, ``fixed`` or ``constant``.
    description : str
        One line for the user.
    start : float or None
        Start value (None for the output, computed).
    unit : str or None
        Unit from the parameter set (None: dimensionless or unknown).
    path : str
        Model field of a parameter (``weights``, ``model.state0``), else ``""``.
    stage : int
        Stage index of a parameter, else -1.
    index : int
        Element index in the field (flattened row by row), else -1.
    lower, upper : float or None
        Hard limits of a valid value (the model field's, :attr:`core.base.Control.lower`
        and ``upper``), declared as ``min`` / ``max`` and checked when the value is set.
    strict : bool
        The lower limit is exclusive (``> lower``).
    above, below : int
        Indices among the parameters of the values this one must stay above and below (an
        increasing field), else -1.
    """

    name: str
    vr: int
    causality: str
    variability: str
    description: str
    start: float | None
    unit: str | None = None
    path: str = ""
    stage: int = -1
    index: int = -1
    lower: float | None = None
    upper: float | None = None
    strict: bool = False
    above: int = -1
    below: int = -1


@dataclass(frozen=True)
class FmuSources:
    """Everything in an FMU but its binary (see :func:`fmu_sources`).

    Attributes
    ----------
    model_identifier : str
        File stem of the source and binary; prefix of the C identifiers.
    fmi_version : int
        3 or 2.
    model_description : str
        ``modelDescription.xml``.
    source : str
        ``sources/<model_identifier>.c`` (one translation unit).
    build_description : str or None
        ``sources/buildDescription.xml`` (FMI 3 only; FMI 2 lists the source in the model
        description).
    readme : str
        ``sources/README.txt``: how to rebuild.
    parameter_set : str
        ``resources/parameter-set.json``: the forward model, units and provenance.
    variables : tuple of FmuVariable
    running : Model
        The model the FMU runs (the forward model, or the causal form of its inverse).
    preview : int
        Samples of the desired trajectory the compensator needs ahead (0: none).
    dt : float or None
        Sample time (s) baked into dynamic stages.
    """

    model_identifier: str
    fmi_version: int
    model_description: str
    source: str
    build_description: str | None
    readme: str
    parameter_set: str
    variables: tuple[FmuVariable, ...]
    running: Model
    preview: int
    dt: float | None

    def parameters(self) -> tuple[FmuVariable, ...]:
        """The model parameters (tunable, fixed and constant ones)."""
        return tuple(v for v in self.variables if v.vr >= FIRST_PARAMETER_VR)


# ----------------------------------------------------------------------------- tools
def fmi_headers(version: int) -> Path:
    """The folder with ``fmi<version>Functions.h``: the copy that ships with ``fmpy``.

    Raises
    ------
    FmuExportError
        If ``fmpy`` is not installed (the message says how to install it).
    """
    spec = importlib.util.find_spec("fmpy")
    origin = None if spec is None else spec.origin
    if origin is not None:
        d = Path(origin).parent / "c-code"
        if (d / f"fmi{version}Functions.h").is_file():
            return d
    raise FmuExportError(
        f"FMU export needs the FMI {version} headers, which come with the fmpy package; "
        "install it with 'pip install fmpy' (or 'pip install hysteresis-explorer[fmu]')"
    )


def find_compiler(compiler: str | None = None) -> str:
    """Path of the C compiler: ``compiler``, else ``$CC``, else ``gcc``.

    Raises
    ------
    FmuExportError
        If it is not on the PATH (the message says how to install gcc).
    """
    name = compiler or os.environ.get("CC") or "gcc"
    path = shutil.which(name)
    if path is None:
        raise FmuExportError(
            f"FMU export compiles the generated C on this machine, but the C compiler {name!r} "
            "was not found on the PATH; install gcc (Debian/Ubuntu: 'apt install gcc') or set "
            "CC to a C99 compiler"
        )
    return path


def _platform(version: int) -> tuple[str, str]:
    """(binaries folder, shared-library suffix) of this machine for FMI ``version``."""
    arch = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64",
            "arm64": "aarch64"}.get(platform.machine().lower(), platform.machine().lower())
    if sys.platform.startswith("linux"):
        system, suffix = "linux", ".so"
    elif sys.platform == "darwin":
        system, suffix = "darwin", ".dylib"
    else:
        raise FmuExportError(
            f"FMU export builds with gcc on Linux or macOS; this is {sys.platform!r}. Build the "
            "FMU on Linux, or compile its sources/ with your compiler"
        )
    if version == 3:
        return f"{arch}-{system}", suffix
    if arch != "x86_64":
        raise FmuExportError(
            f"FMI 2.0 names no binaries folder for {arch}; export with --fmi 3"
        )
    return f"{system}64", suffix


# ----------------------------------------------------------------------------- variables
def _field_values(model: Model, prefix: str = ""
                  ) -> list[tuple[str, Field, np.ndarray, bool]]:
    """``(path, field, values, is_matrix)`` of every numeric field of ``model``, nested models
    included (``model.thresholds``)."""
    out: list[tuple[str, Field, np.ndarray, bool]] = []
    for f in type(model).fields:
        v = getattr(model, f.name, None)
        if v is None:
            continue
        if f.kind == "model":
            out.extend(_field_values(v, f"{prefix}{f.name}."))
        elif f.kind in ("number", "numbers", "matrix", "any"):
            arr = np.asarray(v, dtype=np.float64)
            out.append((f"{prefix}{f.name}", f, arr, arr.ndim == 2))
    return out


def _limits(f: Field, i: int, value: float) -> tuple[float | None, float | None, bool]:
    """(lower, upper, strict) of element ``i`` of field ``f`` (holding ``value``): its
    control's hard limits; an element fixed by the field (the dead zone's 0) is held."""
    if value in f.fixed:
        return value, value, False
    c = f.control_at(i) if f.numeric else None
    if c is None:
        return None, None, False
    return c.lower, c.upper, bool(c.strict and c.lower is not None)


def _rule_words(lower: float | None, upper: float | None, strict: bool, increasing: bool,
                doc: str) -> str:
    words = []
    if lower is not None and lower == upper:
        words.append(f"fixed at {lower:g}")
    else:
        if lower is not None:
            words.append(f"{'>' if strict else '>='} {lower:g}")
        if upper is not None:
            words.append(f"<= {upper:g}")
    if increasing and "increasing" not in doc:
        words.append("increasing")
    return f"; must be {', '.join(words)}" if words else ""


def _unit_of(f: Field, i: int, k: int, n: int, inverse: bool, u_in: str, u_out: str
             ) -> str | None:
    """Unit of element ``i`` of field ``f`` of stage ``k`` (of ``n``): its control's unit
    (:data:`core.base.UNITS`), else the doc's ``(s)``, ``(Hz)``, ``(input units)``,
    ``(output units)``; None for a pure number or an unknown unit.

    The stage that converts units is the first of a model and the last of a compensator:
    before (and at) it a stage's input is in the FMU's input unit, after it in the output
    unit; likewise for its output.
    """
    conv = n - 1 if inverse else 0
    si = u_in if k <= conv else u_out
    so = u_out if k >= conv else u_in
    c = f.control_at(i) if f.numeric else None
    kind = c.unit if c is not None else (
        "s" if "(s)" in f.doc else "Hz" if "(Hz)" in f.doc else
        "input" if "input units" in f.doc else "output" if "output units" in f.doc else "1")
    if kind in ("s", "Hz"):
        return kind
    if kind == "input":
        return si or None
    if kind == "output":
        return so or None
    if kind == "output/input" and si and so and si != so:
        return f"{so}/{si}"
    if kind == "1/input" and si:
        return f"1/{si}"
    return None


# ----------------------------------------------------------------------------- units
#: Non-ASCII characters of unit names and their spelling in the Modelica unit syntax that FMI
#: tools parse (Modelica Language Specification, "Unit Expressions": ASCII, ``u`` for micro).
_ASCII_UNIT = {"\u00b5": "u", "\u03bc": "u", "\u2126": "Ohm", "\u03a9": "Ohm",
               "\u00b0": "deg", "\u00b2": "2", "\u00b3": "3", "\u00b7": "."}
#: SI base-unit exponents (kg, m, s, A, K, mol, cd, rad) and factor of the symbols known here.
_SI: dict[str, tuple[tuple[int, ...], float]] = {
    "m": ((0, 1, 0, 0, 0, 0, 0, 0), 1.0), "g": ((1, 0, 0, 0, 0, 0, 0, 0), 1e-3),
    "s": ((0, 0, 1, 0, 0, 0, 0, 0), 1.0), "A": ((0, 0, 0, 1, 0, 0, 0, 0), 1.0),
    "K": ((0, 0, 0, 0, 1, 0, 0, 0), 1.0), "mol": ((0, 0, 0, 0, 0, 1, 0, 0), 1.0),
    "rad": ((0, 0, 0, 0, 0, 0, 0, 1), 1.0), "Hz": ((0, 0, -1, 0, 0, 0, 0, 0), 1.0),
    "N": ((1, 1, -2, 0, 0, 0, 0, 0), 1.0), "Pa": ((1, -1, -2, 0, 0, 0, 0, 0), 1.0),
    "J": ((1, 2, -2, 0, 0, 0, 0, 0), 1.0), "W": ((1, 2, -3, 0, 0, 0, 0, 0), 1.0),
    "V": ((1, 2, -3, -1, 0, 0, 0, 0), 1.0), "Ohm": ((1, 2, -3, -2, 0, 0, 0, 0), 1.0),
    "C": ((0, 0, 1, 1, 0, 0, 0, 0), 1.0), "T": ((1, 0, -2, -1, 0, 0, 0, 0), 1.0),
    "Wb": ((1, 2, -2, -1, 0, 0, 0, 0), 1.0), "H": ((1, 2, -2, -2, 0, 0, 0, 0), 1.0),
    "F": ((-1, -2, 4, 2, 0, 0, 0, 0), 1.0), "deg": ((0, 0, 0, 0, 0, 0, 0, 1), np.pi / 180),
    "min": ((0, 0, 1, 0, 0, 0, 0, 0), 60.0), "h": ((0, 0, 1, 0, 0, 0, 0, 0), 3600.0),
}
_PREFIX = {"p": 1e-12, "n": 1e-9, "u": 1e-6, "m": 1e-3, "c": 1e-2, "d": 1e-1, "k": 1e3,
           "M": 1e6, "G": 1e9}
_BASE_NAMES = ("kg", "m", "s", "A", "K", "mol", "cd", "rad")
_FACTOR = re.compile(r"([A-Za-z]+)(-?\d+)?")


def fmi_unit(unit: str) -> str:
    """A unit name in the ASCII spelling FMI tools expect: ``µm`` -> ``um``, ``Ω`` -> ``Ohm``,
    ``m²`` -> ``m2`` (the Modelica unit syntax FMI 2 and 3 refer to; a non-ASCII name is
    legal XML but a tool parsing unit expressions does not know it)."""
    return "".join(_ASCII_UNIT.get(ch, ch) for ch in unit)


def _symbol(token: str) -> tuple[tuple[int, ...], float] | None:
    if token in _SI:
        return _SI[token]
    if len(token) > 1 and token[0] in _PREFIX and token[1:] in _SI:
        exps, factor = _SI[token[1:]]
        return exps, factor * _PREFIX[token[0]]
    return None


def base_unit(unit: str) -> tuple[dict[str, int], float] | None:
    """SI base-unit exponents and factor of an (ASCII) unit name, e.g. ``"um/V"`` ->
    ``({"kg": -1, "m": -1, "s": 3, "A": 1}, 1e-6)``; None when a symbol is not one of the
    SI units and prefixes known here (the unit is then declared without a ``BaseUnit``).

    The grammar: factors ``<prefix><symbol><exponent>`` joined by ``.`` or ``*``, at most
    one ``/`` before the denominator's factors; ``1`` stands for no factor.
    """
    parts = unit.split("/")
    if len(parts) > 2 or not unit:
        return None
    exps, factor = [0] * 8, 1.0
    for side, sign in zip(parts, (1, -1), strict=False):
        for item in re.split(r"[.*]", side.strip()):
            if item == "1" and sign == 1:
                continue
            m = _FACTOR.fullmatch(item)
            sym = _symbol(m.group(1)) if m else None
            if m is None or sym is None:
                return None
            power = sign * int(m.group(2) or 1)
            exps = [e + power * x for e, x in zip(exps, sym[0], strict=True)]
            factor *= sym[1] ** power
    return {n: e for n, e in zip(_BASE_NAMES, exps, strict=True) if e}, factor


def _element_name(base: str, path: str, arr: np.ndarray, idx: int, is_matrix: bool) -> str:
    if arr.ndim == 0:
        return f"{base}.{path}"
    if is_matrix:
        r, c = divmod(idx, arr.shape[1])
        return f"{base}.{path}[{r + 1},{c + 1}]"
    return f"{base}.{path}[{idx + 1}]"


# ----------------------------------------------------------------------------- generation
_PLACEHOLDER = re.compile(r"\$([A-Za-z_][A-Za-z0-9_.]*)")


def _tuned(offsets: dict[str, int], m: re.Match[str]) -> str:
    """A tune line's ``$field`` as its place in the parameter block ``mp``."""
    return f"(mp + {offsets[m.group(1)]})"


def _parameters(stages: list[Model], emitted: list, role: str, units: Units
                ) -> tuple[list[FmuVariable], list[str]]:
    """The parameter variables of every stage (value references from
    :data:`FIRST_PARAMETER_VR`, in order) and the tune lines with ``$field`` resolved to the
    C array ``mp`` of their values."""
    variables: list[FmuVariable] = []
    tune_lines: list[str] = []
    n, inverse = len(stages), role == "compensator"
    for k, (stage, em) in enumerate(zip(stages, emitted, strict=True)):
        base = stage.type_name.replace("-", "_")
        base = base if n == 1 else f"s{k}_{base}"
        tuned = set(_PLACEHOLDER.findall("\n".join(em.tune)))
        offsets: dict[str, int] = {}
        for path, fld, arr, is_matrix in _field_values(stage):
            doc = fld.doc
            start = offsets[path] = len(variables)
            state = path.rsplit(".", 1)[-1] in _STATE_FIELDS
            variability = ("fixed" if state else "tunable") if path in tuned else "constant"
            note = "" if variability != "constant" else \
                " [fixed at export: its C constants need the export's numerics; re-export]"
            flat = arr.ravel()
            increasing = fld.increasing and arr.ndim == 1 and flat.size > 1
            for i, v in enumerate(flat):
                lo, hi, strict = _limits(fld, i, float(v))
                rule = _rule_words(lo, hi, strict, increasing, doc)
                unit = _unit_of(fld, i, k, n, inverse, fmi_unit(units.input),
                                fmi_unit(units.output))
                variables.append(FmuVariable(
                    _element_name(base, path, arr, i, is_matrix),
                    FIRST_PARAMETER_VR + len(variables),
                    "parameter" if variability != "constant" else "local", variability,
                    f"{role} stage {k} ({stage.type_name}): {doc}{rule}{note}", float(v),
                    unit or None, path, k, i, lo, hi, strict,
                    start + i - 1 if increasing and i > 0 else -1,
                    start + i + 1 if increasing and i + 1 < flat.size else -1))
        missing = tuned - set(offsets)
        if missing:  # pragma: no cover - emitters name their own fields
            raise CExportError(f"tune lines of {stage.type_name!r} name unknown fields {missing}")
        for line in em.tune:
            tune_lines.append(
                _PLACEHOLDER.sub(functools.partial(_tuned, offsets), line))
    return variables, tune_lines


#: Stage types of a compensator whose slopes ``p0 + p1 + ... + p_j`` must stay positive: the
#: PI inverse (itself a PI) and the rate-dependent PI's inverse (a bisection on its slopes).
_SLOPE_TYPES = ("pi", "rate-inverse")


def _slope_rules(params: list[FmuVariable], stages: list[Model]
                 ) -> tuple[tuple[int, int, int], ...]:
    """``(p0, first weight, number of weights)`` (indices among ``params``) of every stage of
    :data:`_SLOPE_TYPES` whose ``p0`` and weights are tunable."""
    out = []
    by = {(v.stage, v.path, v.index): i for i, v in enumerate(params)}
    for i, v in enumerate(params):
        if v.path != "p0" or v.variability != "tunable" or \
                stages[v.stage].type_name not in _SLOPE_TYPES:
            continue
        w = by.get((v.stage, "weights", 0))
        if w is None or params[w].variability != "tunable":
            continue
        n = sum(1 for u in params if u.stage == v.stage and u.path == "weights")
        out.append((i, w, n))
    return tuple(out)


def fmu_sources(
    model: Model | ParameterSet,
    *,
    fmi_version: int = 3,
    inverse: bool = False,
    dt: float | None = None,
    name: str = "hysteresis",
) -> FmuSources:
    """Generate the model description, C source and build description of an FMU.

    Parameters
    ----------
    model : Model or ParameterSet
        The forward model (a parameter set brings units and provenance).
    fmi_version : {3, 2}
    inverse : bool
        Run the inverse compensator (desired output in, drive out) instead of the model.
    dt : float, optional
        Sample time in seconds; required when a stage has dynamics (``needs_dt``).
    name : str
        Model identifier (file stem, C prefix): made into a C identifier.

    Returns
    -------
    FmuSources

    Raises
    ------
    FmuExportError
        Unknown FMI version, missing ``dt``, no FMI headers.
    CExportError
        A stage type without a C emitter.
    NotInvertibleError
        ``inverse`` and the model has no inverse.
    """
    from .paramset import ParameterSet

    if fmi_version not in FMI_VERSIONS:
        raise FmuExportError(
            f"unknown FMI version {fmi_version!r}; choose "
            + " or ".join(str(v) for v in FMI_VERSIONS)
        )
    ps = model if isinstance(model, ParameterSet) else ParameterSet.from_model(model)
    fwd = ps.model
    if dt is not None and not (np.isfinite(dt) and dt > 0):
        raise FmuExportError(f"the sample time dt must be a positive number of seconds, got {dt!r}")
    if fwd.is_dynamic and dt is None:
        raise FmuExportError(
            f"the {fwd.type_name!r} model has dynamics, so its FMU runs at a fixed sample time; "
            "give it, e.g. dt=1e-4 (--dt 1e-4 on the command line)"
        )
    ident = c_identifier(name)
    running, preview = causal_compensator(fwd, dt) if inverse else (fwd, 0)
    units = ps.units.swapped() if inverse else ps.units
    block, role = f"{ident}_m", "compensator" if inverse else "model"
    stages, emitted = emit_stages(running, block, dt, role)
    header, body, _ = _emit_block(running, block, dt, role, params=f"{ident}_P_",
                                  emitted=emitted)

    in_name, out_name = ("y_ref", "u") if inverse else ("u", "y")
    variables = _io_variables(fmi_version, inverse, dt, preview, units)
    params, tune_lines = _parameters(stages, emitted, role, units)
    variables += params

    tune_helpers = [line for em in emitted for line in em.tune_helpers]
    src = fmu_c_source(FmuCode(
        ident, fmi_version, header, "\n".join([body, *tune_helpers]),
        tuple(parse_constant(d) for em in emitted for d in em.constants), tuple(tune_lines),
        tuple(float(filled(v.start)) for v in params),  # a parameter always starts
        tuple({"tunable": 1, "fixed": 2, "constant": 0}[v.variability] for v in params),
        dt, preview, inverse, FIRST_PARAMETER_VR, tuple(v.name for v in params),
        tuple((v.lower, v.upper, v.strict, v.above, v.below) for v in params),
        (in_name, out_name), _slope_rules(params, stages) if inverse else ()),
        fmi_headers(fmi_version))
    token = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, hashlib.sha256(
        (src + str(fmi_version)).encode()).hexdigest())) + "}"
    src = src.replace("@TOKEN@", token)
    doc_text = _description(ps, fwd, inverse, preview, dt, units, len(stages), stages)
    xml = (_xml3 if fmi_version == 3 else _xml2)(
        ps, ident, token, doc_text, variables, dt)
    build = _build_description(ident) if fmi_version == 3 else None
    readme = _readme(ident, fmi_version)
    return FmuSources(ident, fmi_version, xml, src, build, readme, ps.to_json(),
                      tuple(variables), running, preview, dt)


def _io_variables(fmi_version: int, inverse: bool, dt: float | None, preview: int,
                  units: Units) -> list[FmuVariable]:
    """The FMU's variables before its parameters: time (FMI 3), the input, the output, the
    fixed sample time (with dynamics) and the compensator's preview (with ``inverse``)."""
    in_name, out_name = ("y_ref", "u") if inverse else ("u", "y")
    variables: list[FmuVariable] = []
    u_in, u_out = fmi_unit(units.input) or None, fmi_unit(units.output) or None
    if fmi_version == 3:
        variables.append(FmuVariable("time", 0, "independent", "continuous",
                                     "simulation time (s)", None, "s"))
    variables.append(FmuVariable(
        in_name, 1, "input", "continuous",
        ("desired output of the actuator (the compensator's set point)" if inverse
         else "actuator drive (model input)") + ", held over each step; must be finite",
        0.0, u_in))
    variables.append(FmuVariable(
        out_name, 2, "output", "discrete",
        ("drive that makes the actuator follow y_ref" if inverse else "model output")
        + " (its value at the last sample of the step)", None, u_out))
    if dt is not None:
        variables.append(FmuVariable(
            "sample_time", 3, "parameter", "fixed",
            "sample time of the dynamic stages (s), fixed at export (their discretisation "
            "uses it; re-export with another --dt to change it)", float(dt), "s",
            lower=float(dt), upper=float(dt)))
    if inverse:
        variables.append(FmuVariable(
            "preview_samples", 4, "calculatedParameter", "fixed",
            "samples of the desired trajectory the compensator needs ahead: feed y_ref "
            "this many samples early (0: none)", None, lower=float(preview),
            upper=float(preview)))
    return variables


def _description(ps: ParameterSet, fwd: Model, inverse: bool, preview: int, dt: float | None,
                 units, n: int, stages: list[Model]) -> str:
    chain = " -> ".join(s.type_name for s in stages)
    u_in, u_out = fmi_unit(ps.units.input) or "-", fmi_unit(ps.units.output) or "-"
    parts = [
        (f"Inverse compensator of a {fwd.type_name} hysteresis model: desired output "
         f"({u_out}) in, actuator drive ({u_in}) out"
         if inverse else
         f"{fwd.type_name} hysteresis model: drive ({u_in}) in, output ({u_out}) out"),
        f"{n} stage(s): {chain}",
    ]
    if dt is not None:
        parts.append(f"fixed sample time {dt:.12g} s: a step runs the samples "
                     "whose instants it reaches with the input held (one per step when the "
                     "step is the sample time) and holds any remainder")
    else:
        parts.append("no dynamics: each step is one sample of the (rate-independent) model")
    if inverse:
        parts.append(f"preview {preview} sample(s) ({'feed y_ref ' + str(preview) + ' samples ahead; the first outputs are warm-up' if preview else 'none needed'})")  # noqa: E501
    if ps.provenance.source:
        parts.append(f"source: {ps.provenance.source}")
    return "; ".join(parts) + "."


def _licence(ps: ParameterSet) -> str:
    lic = ps.provenance.extra.get("license") or ps.provenance.extra.get("licence")
    return (f"parameter set: {lic}; " if isinstance(lic, str) else
            "parameter set: as its provenance (resources/parameter-set.json) states; ") + \
        "generated code: MIT (hysteresis-explorer)"




def _header_attrs(ps: ParameterSet, ident: str, doc_text: str) -> str:
    prov = ps.provenance
    extra = {k: v for k, v in prov.extra.items() if k in ("author", "copyright")
             and isinstance(v, str)}  # only what the parameter set states
    attrs = {
        "modelName": ident,
        "description": doc_text,
        **({"author": extra["author"]} if "author" in extra else {}),
        "version": prov.created,
        **({"copyright": extra["copyright"]} if "copyright" in extra else {}),
        "license": _licence(ps),
        "generationTool": prov.tool,
        "generationDateAndTime": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "structured",
    }
    return " ".join(f"{k}={xml_attr(v)}" for k, v in attrs.items())


_LOG_CATEGORIES = [
    "  <LogCategories>",
    '    <Category name="logStatusDiscard" description="values refused, the FMU as before the '
    'call: a NaN or infinite input, a parameter outside its limits, out of order or making '
    'the compensator non-invertible, a step whose output would not be finite"/>',
    '    <Category name="logStatusError" description="calls refused: a negative or '
    'non-finite step, a parameter fixed at export, an unknown value reference"/>',
    "  </LogCategories>",
]


def _units_xml(variables: list[FmuVariable]) -> list[str]:
    """The unit definitions: every unit a variable uses, with its SI ``BaseUnit`` when the
    unit is made of the symbols :func:`base_unit` knows."""
    units = sorted({v.unit for v in variables if v.unit})
    if not units:
        return []
    lines = ["  <UnitDefinitions>"]
    for u in units:
        base = base_unit(u)
        if base is None:
            lines.append(f"    <Unit name={xml_attr(u)}/>")
            continue
        exps, factor = base
        attrs = "".join(f' {k}="{e}"' for k, e in exps.items())
        if factor != 1.0:
            attrs += f' factor="{factor!r}"'
        lines += [f"    <Unit name={xml_attr(u)}>", f"      <BaseUnit{attrs}/>", "    </Unit>"]
    return [*lines, "  </UnitDefinitions>"]


def _value_attrs(v: FmuVariable) -> str:
    """``unit``, ``min``, ``max`` and ``start`` of a variable (the common attributes of an
    FMI 3 ``Float64`` and an FMI 2 ``Real``)."""
    a = []
    if v.unit:
        a.append(f"unit={xml_attr(v.unit)}")
    if v.lower is not None:
        a.append(f'min="{c_double(v.lower)}"')
    if v.upper is not None:
        a.append(f'max="{c_double(v.upper)}"')
    if v.start is not None:
        a.append(f'start="{c_double(v.start)}"')
    return " ".join(a)


def _var_attrs(v: FmuVariable) -> str:
    a = f"name={xml_attr(v.name)} valueReference=\"{v.vr}\" causality=\"{v.causality}\" " \
        f"variability=\"{v.variability}\""
    return a + f" description={xml_attr(v.description)}"


def _head(ps: ParameterSet, ident: str, doc_text: str, version: str,
          token: str) -> list[str]:
    """The XML declaration and the root element's opening tag (``token``: its attribute)."""
    return ['<?xml version="1.0" encoding="UTF-8"?>',
            f'<fmiModelDescription fmiVersion="{version}" '
            f'{_header_attrs(ps, ident, doc_text)} {token}>']


def _experiment(dt: float | None) -> str:
    return ('  <DefaultExperiment startTime="0"'
            + (f' stepSize="{c_double(dt)}"' if dt is not None else "") + "/>")


def _xml3(ps, ident, token, doc_text, variables, dt) -> str:
    lines = [*_head(ps, ident, doc_text, "3.0", f'instantiationToken="{token}"'),
             f'  <CoSimulation modelIdentifier="{ident}" '
             'canHandleVariableCommunicationStepSize="true" '
             + (f'fixedInternalStepSize="{c_double(dt)}" ' if dt is not None else "")
             + 'canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUState="false" '
             'canSerializeFMUState="false" hasEventMode="false" '
             'providesIntermediateUpdate="false" canReturnEarlyAfterIntermediateUpdate="false"/>',
             *_units_xml(variables),
             *_LOG_CATEGORIES,
             _experiment(dt),
             "  <ModelVariables>"]
    for v in variables:
        a = _var_attrs(v)
        if v.causality in ("output", "calculatedParameter"):
            a += ' initial="calculated"'
        values = _value_attrs(v)
        lines.append(f"    <Float64 {a}{' ' + values if values else ''}/>")
    lines += ["  </ModelVariables>", "  <ModelStructure>",
              '    <Output valueReference="2"/>', '    <InitialUnknown valueReference="2"/>',
              *(f'    <InitialUnknown valueReference="{v.vr}" dependencies=""/>'
                for v in variables if v.causality == "calculatedParameter"),
              "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def _xml2(ps, ident, token, doc_text, variables, dt) -> str:
    lines = [*_head(ps, ident, doc_text, "2.0", f'guid="{token}"'),
             f'  <CoSimulation modelIdentifier="{ident}" '
             'canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false" '
             'canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUstate="false" '
             'canSerializeFMUstate="false" canNotUseMemoryManagementFunctions="true">',
             "    <SourceFiles>", f'      <File name="{ident}.c"/>', "    </SourceFiles>",
             "  </CoSimulation>",
             *_units_xml(variables),
             *_LOG_CATEGORIES,
             _experiment(dt),
             "  <ModelVariables>"]
    out_index, calculated = 0, []
    for i, v in enumerate(variables, start=1):
        a = _var_attrs(v)
        if v.causality == "output":
            a += ' initial="calculated"'
            out_index = i
        elif v.causality == "calculatedParameter":
            a += ' initial="calculated"'
            calculated.append(i)
        values = _value_attrs(v)
        lines.append(f"    <ScalarVariable {a}>")
        lines.append(f"      <Real{' ' + values if values else ''}/>")
        lines.append("    </ScalarVariable>")
    lines += ["  </ModelVariables>", "  <ModelStructure>",
              "    <Outputs>", f'      <Unknown index="{out_index}"/>', "    </Outputs>",
              "    <InitialUnknowns>", f'      <Unknown index="{out_index}"/>',
              *(f'      <Unknown index="{i}" dependencies=""/>' for i in calculated),
              "    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def _build_description(ident: str) -> str:
    return "\n".join([
        '<?xml version="1.0" encoding="UTF-8"?>',
        '<fmiBuildDescription fmiVersion="3.0">',
        f'  <BuildConfiguration modelIdentifier="{ident}" '
        'description="one C99 translation unit; link with the math library">',
        '    <SourceFileSet language="C99">',
        f'      <SourceFile name="{ident}.c"/>',
        "    </SourceFileSet>",
        '    <Library name="m" description="the C math library (exp, tanh, atanh, fabs)"/>',
        "  </BuildConfiguration>",
        "</fmiBuildDescription>", ""])


def _readme(ident: str, version: int) -> str:
    return "\n".join([
        f"{ident}.c is the whole FMU (FMI {version}.0 co-simulation), generated by "
        "hysteresis-explorer.",
        f"It needs the FMI {version}.0 headers (fmi{version}Functions.h and the files it "
        "includes), which every FMI importer ships.",
        "Rebuild the binary for your platform, e.g.:",
        f"  cc -std=c99 -O2 -shared -fPIC -I<FMI {version} headers> -o {ident}.so {ident}.c -lm",
        "and put it in binaries/<platform>/ of the FMU (a zip file).",
        "",
    ])


# ----------------------------------------------------------------------------- build
def build_fmu(
    model: Model | ParameterSet,
    path: str | Path,
    *,
    fmi_version: int = 3,
    inverse: bool = False,
    dt: float | None = None,
    name: str | None = None,
    compiler: str | None = None,
) -> Path:
    """Generate, compile and zip an FMU at ``path`` (``.fmu`` added if missing).

    Parameters
    ----------
    model : Model or ParameterSet
    path : str or Path
        Output file.
    fmi_version, inverse, dt
        See :func:`fmu_sources`.
    name : str, optional
        Model identifier; defaults to the file stem made into a C identifier.
    compiler : str, optional
        C compiler (default ``$CC`` or ``gcc``).

    Returns
    -------
    Path
        The FMU written.

    Raises
    ------
    FmuExportError
        Bad options, no compiler or headers, or the compiler failed (its message quoted).
    """
    out = Path(path)
    if out.suffix.lower() != ".fmu":
        out = out.with_name(out.name + ".fmu")
    src = fmu_sources(model, fmi_version=fmi_version, inverse=inverse, dt=dt,
                      name=name or out.stem)
    plat, suffix = _platform(fmi_version)
    cc = find_compiler(compiler)
    ident = src.model_identifier
    with tempfile.TemporaryDirectory(prefix="hyst-fmu-") as tmp:
        c_file = Path(tmp) / f"{ident}.c"
        lib = Path(tmp) / f"{ident}{suffix}"
        c_file.write_text(src.source, encoding="utf-8")
        proc = subprocess.run(
            [cc, "-std=c99", "-O2", "-shared", "-fPIC", "-fvisibility=hidden", "-Wall",
             "-Wextra", "-I", str(fmi_headers(fmi_version)), "-o", str(lib), str(c_file), "-lm"],
            capture_output=True, text=True, check=False,
        )
        if proc.returncode != 0:
            raise FmuExportError(
                f"compiling the FMU with {cc} failed (exit {proc.returncode}):\n"
                + proc.stderr[-3000:]
            )
        out.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as zf:
            zf.writestr("modelDescription.xml", src.model_description)
            zf.write(lib, f"binaries/{plat}/{ident}{suffix}")
            zf.writestr(f"sources/{ident}.c", src.source)
            if src.build_description is not None:
                zf.writestr("sources/buildDescription.xml", src.build_description)
            zf.writestr("sources/README.txt", src.readme)
            zf.writestr("resources/parameter-set.json", src.parameter_set)
    return out
