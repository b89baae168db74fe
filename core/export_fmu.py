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
  a virgin state unless the model says otherwise), and a ``constant`` where the constants
  need the export's numerics (matrix exponentials, root finding: re-export to change it);
- ``sample_time`` (``dt``, constant) and ``preview_samples`` (the compensator's preview,
  :func:`core.effects.causal_form`; also stated in the model description).

Stepping: one ``doStep`` of size ``h`` runs ``h / dt`` samples with the input held (``h`` must
be a whole number of samples); without dynamics (no ``dt``) one ``doStep`` is one sample. The
output after a step is the model's output at the last sample, so feeding ``u[k]`` and
stepping ``dt`` reproduces ``model.simulate(u)[k]``.

The FMI headers are not part of this repository: they come with ``fmpy`` (its ``c-code``
folder), found at build time (:func:`fmi_headers`).
"""

from __future__ import annotations

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
from xml.sax.saxutils import quoteattr

import numpy as np

from .base import Model
from .export_c import (
    CExportError,
    _emit_block,
    c_double,
    c_identifier,
    causal_compensator,
    emit_stages,
    parse_constant,
)

if TYPE_CHECKING:
    from .paramset import ParameterSet, Units

__all__ = [
    "FMI_VERSIONS",
    "FmuExportError",
    "FmuSources",
    "FmuVariable",
    "build_fmu",
    "find_compiler",
    "fmi_headers",
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
def _field_values(model: Model, prefix: str = "") -> list[tuple[str, str, np.ndarray, bool]]:
    """``(path, doc, values (flattened), is_matrix)`` of every numeric field of ``model``,
    nested models included (``model.thresholds``)."""
    out: list[tuple[str, str, np.ndarray, bool]] = []
    for f in type(model).fields:
        v = getattr(model, f.name, None)
        if v is None:
            continue
        if f.kind == "model":
            out.extend(_field_values(v, f"{prefix}{f.name}."))
        elif f.kind in ("number", "numbers", "matrix", "any"):
            arr = np.asarray(v, dtype=np.float64)
            out.append((f"{prefix}{f.name}", f.doc, arr, arr.ndim == 2))
    return out


def _unit_of(doc: str, k: int, n: int, inverse: bool, u_in: str, u_out: str, t: str) -> str | None:
    """Unit of a field from its doc: ``(s)``, ``(Hz)``, ``(input units)``, ``(output units)``.

    Stage inputs: the model's input before (and at) the stage that converts units (the first
    stage of a model, the last of a compensator), its output after; likewise for outputs.
    """
    if "(s)" in doc:
        return t
    if "(Hz)" in doc:
        return "Hz"
    conv = n - 1 if inverse else 0
    if "input units" in doc:
        return u_in if k <= conv else u_out
    if "output units" in doc:
        return u_out if k >= conv else u_in
    return None


def _element_name(base: str, path: str, arr: np.ndarray, idx: int, is_matrix: bool) -> str:
    if arr.ndim == 0:
        return f"{base}.{path}"
    if is_matrix:
        r, c = divmod(idx, arr.shape[1])
        return f"{base}.{path}[{r + 1},{c + 1}]"
    return f"{base}.{path}[{idx + 1}]"


# ----------------------------------------------------------------------------- generation
_PLACEHOLDER = re.compile(r"\$([A-Za-z_][A-Za-z0-9_.]*)")


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
        for path, doc, arr, is_matrix in _field_values(stage):
            offsets[path] = len(variables)
            state = path.rsplit(".", 1)[-1] in _STATE_FIELDS
            variability = ("fixed" if state else "tunable") if path in tuned else "constant"
            unit = _unit_of(doc, k, n, inverse, units.input, units.output, units.time)
            note = "" if variability != "constant" else \
                " [fixed at export: its C constants need the export's numerics; re-export]"
            for i, v in enumerate(arr.ravel()):
                variables.append(FmuVariable(
                    _element_name(base, path, arr, i, is_matrix),
                    FIRST_PARAMETER_VR + len(variables),
                    "parameter" if variability != "constant" else "local", variability,
                    f"{role} stage {k} ({stage.type_name}): {doc}{note}", float(v),
                    unit or None, path, k, i))
        missing = tuned - set(offsets)
        if missing:  # pragma: no cover - emitters name their own fields
            raise CExportError(f"tune lines of {stage.type_name!r} name unknown fields {missing}")
        for line in em.tune:
            tune_lines.append(
                _PLACEHOLDER.sub(lambda m, o=offsets: f"(mp + {o[m.group(1)]})", line))
    return variables, tune_lines


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
    units = type(units)(*(_NOT_XML.sub("?", u) for u in (units.input, units.output, units.time)))
    block, role = f"{ident}_m", "compensator" if inverse else "model"
    stages, emitted = emit_stages(running, block, dt, role)
    header, body, _ = _emit_block(running, block, dt, role, params=f"{ident}_P_",
                                  emitted=emitted)

    # ---- variables
    in_name, out_name = ("y_ref", "u") if inverse else ("u", "y")
    what = "inverse compensator" if inverse else "hysteresis model"
    variables: list[FmuVariable] = []
    if fmi_version == 3:
        variables.append(FmuVariable("time", 0, "independent", "continuous",
                                     "simulation time", None, units.time or None))
    variables.append(FmuVariable(
        in_name, 1, "input", "continuous",
        ("desired output of the actuator (the compensator's set point)" if inverse
         else "actuator drive (model input)") + ", held over each step",
        0.0, units.input or None))
    variables.append(FmuVariable(
        out_name, 2, "output", "discrete",
        ("drive that makes the actuator follow y_ref" if inverse else "model output")
        + " (its value at the last sample of the step)", None, units.output or None))
    if dt is not None:
        variables.append(FmuVariable("sample_time", 3, "local", "constant",
                                     "sample time of the dynamic stages (s): step in multiples",
                                     float(dt), units.time or None))
    if inverse:
        variables.append(FmuVariable(
            "preview_samples", 4, "local", "constant",
            "samples of the desired trajectory the compensator needs ahead: feed y_ref "
            "this many samples early (0: none)", float(preview)))
    params, tune_lines = _parameters(stages, emitted, role, units)
    variables += params
    mp0 = [float(v.start) for v in params]  # type: ignore[arg-type]
    kinds = [{"tunable": 1, "fixed": 2, "constant": 0}[v.variability] for v in params]

    tune_helpers = [line for em in emitted for line in em.tune_helpers]
    # ---- C source
    consts = [parse_constant(d) for em in emitted for d in em.constants]
    struct = [f"    {ctype} {cid}{'' if size is None else f'[{size}]'};"
              for ctype, cid, size, _ in consts] or ["    int unused_;"]
    defaults = [f"    {init}," for *_, init in consts] or ["    0,"]
    nmp = max(len(mp0), 1)
    finite = [f"    if (!isfinite({cid})) return 0;" if size is None else
              f"    for (i = 0; i < {size}u; ++i) if (!isfinite({cid}[i])) return 0;"
              for ctype, cid, size, _ in consts if ctype == "double"]
    src = _c_source(ident, fmi_version, header, "\n".join([body, *tune_helpers]), struct,
                    defaults, tune_lines, mp0, kinds, nmp, dt, preview, inverse, finite)
    token = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, hashlib.sha256(
        (src + str(fmi_version)).encode()).hexdigest())) + "}"
    src = src.replace("@TOKEN@", token)
    doc_text = _description(ps, fwd, inverse, preview, dt, units, len(stages), stages)
    xml = (_xml3 if fmi_version == 3 else _xml2)(
        ps, ident, token, doc_text, variables, dt, what)
    build = _build_description(ident) if fmi_version == 3 else None
    readme = _readme(ident, fmi_version)
    return FmuSources(ident, fmi_version, xml, src, build, readme, ps.to_json(),
                      tuple(variables), running, preview, dt)


def _description(ps: ParameterSet, fwd: Model, inverse: bool, preview: int, dt: float | None,
                 units, n: int, stages: list[Model]) -> str:
    chain = " -> ".join(s.type_name for s in stages)
    parts = [
        (f"Inverse compensator of a {fwd.type_name} hysteresis model: desired output "
         f"({ps.units.output or '-'}) in, actuator drive ({ps.units.input or '-'}) out"
         if inverse else
         f"{fwd.type_name} hysteresis model: drive ({ps.units.input or '-'}) in, output "
         f"({ps.units.output or '-'}) out"),
        f"{n} stage(s): {chain}",
    ]
    if dt is not None:
        parts.append(f"fixed sample time {dt:.12g} {units.time}: each step must be a whole "
                     "number of samples, the input is held over the step")
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


_NOT_XML = re.compile("[^\t\n\r\x20-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


def _attr(text: str) -> str:
    """``text`` as a quoted XML attribute value; characters XML 1.0 cannot hold (control
    characters, lone surrogates: a parameter set's free text may have them) become ``?``."""
    return quoteattr(_NOT_XML.sub("?", text))


def _header_attrs(ps: ParameterSet, ident: str, what: str, doc_text: str) -> str:
    prov = ps.provenance
    extra = {k: v for k, v in prov.extra.items() if k in ("author", "copyright")
             and isinstance(v, str)}  # only what the parameter set states
    attrs = {
        "modelName": f"{ident} ({what})",
        "description": doc_text,
        **({"author": extra["author"]} if "author" in extra else {}),
        "version": prov.created,
        **({"copyright": extra["copyright"]} if "copyright" in extra else {}),
        "license": _licence(ps),
        "generationTool": prov.tool,
        "generationDateAndTime": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "variableNamingConvention": "structured",
    }
    return " ".join(f"{k}={_attr(v)}" for k, v in attrs.items())


_LOG_CATEGORIES = [
    "  <LogCategories>",
    '    <Category name="logStatusError" description="calls refused: a step that is not a '
    'whole number of samples, a parameter fixed at export, an unknown value reference"/>',
    "  </LogCategories>",
]


def _units_xml(variables: list[FmuVariable]) -> list[str]:
    units = sorted({v.unit for v in variables if v.unit})
    if not units:
        return []
    return ["  <UnitDefinitions>", *(f"    <Unit name={_attr(u)}/>" for u in units),
            "  </UnitDefinitions>"]


def _var_attrs(v: FmuVariable) -> str:
    a = f"name={_attr(v.name)} valueReference=\"{v.vr}\" causality=\"{v.causality}\" " \
        f"variability=\"{v.variability}\""
    return a + f" description={_attr(v.description)}"


def _xml3(ps, ident, token, doc_text, variables, dt, what) -> str:
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="3.0" {_header_attrs(ps, ident, what, doc_text)} '
             f'instantiationToken="{token}">',
             f'  <CoSimulation modelIdentifier="{ident}" '
             'canHandleVariableCommunicationStepSize="true" '
             + (f'fixedInternalStepSize="{c_double(dt)}" ' if dt is not None else "")
             + 'canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUState="false" '
             'canSerializeFMUState="false" hasEventMode="false" '
             'providesIntermediateUpdate="false" canReturnEarlyAfterIntermediateUpdate="false"/>',
             *_units_xml(variables),
             *_LOG_CATEGORIES,
             '  <DefaultExperiment startTime="0"'
             + (f' stepSize="{c_double(dt)}"' if dt is not None else "") + "/>",
             "  <ModelVariables>"]
    for v in variables:
        a = _var_attrs(v)
        if v.unit:
            a += f" unit={_attr(v.unit)}"
        if v.causality == "output":
            a += ' initial="calculated"'
        if v.start is not None:
            a += f' start="{c_double(v.start)}"'
        lines.append(f"    <Float64 {a}/>")
    lines += ["  </ModelVariables>", "  <ModelStructure>",
              '    <Output valueReference="2"/>', '    <InitialUnknown valueReference="2"/>',
              "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(lines)


def _xml2(ps, ident, token, doc_text, variables, dt, what) -> str:
    lines = ['<?xml version="1.0" encoding="UTF-8"?>',
             f'<fmiModelDescription fmiVersion="2.0" {_header_attrs(ps, ident, what, doc_text)} '
             f'guid="{token}">',
             f'  <CoSimulation modelIdentifier="{ident}" '
             'canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false" '
             'canBeInstantiatedOnlyOncePerProcess="false" canGetAndSetFMUstate="false" '
             'canSerializeFMUstate="false" canNotUseMemoryManagementFunctions="true">',
             "    <SourceFiles>", f'      <File name="{ident}.c"/>', "    </SourceFiles>",
             "  </CoSimulation>",
             *_units_xml(variables),
             *_LOG_CATEGORIES,
             '  <DefaultExperiment startTime="0"'
             + (f' stepSize="{c_double(dt)}"' if dt is not None else "") + "/>",
             "  <ModelVariables>"]
    out_index = 0
    for i, v in enumerate(variables, start=1):
        a = _var_attrs(v)
        if v.causality == "output":
            a += ' initial="calculated"'
            out_index = i
        real = []
        if v.unit:
            real.append(f"unit={_attr(v.unit)}")
        if v.start is not None:
            real.append(f'start="{c_double(v.start)}"')
        lines.append(f"    <ScalarVariable {a}>")
        lines.append(f"      <Real {' '.join(real)}/>".replace("<Real />", "<Real/>"))
        lines.append("    </ScalarVariable>")
    lines += ["  </ModelVariables>", "  <ModelStructure>",
              "    <Outputs>", f'      <Unknown index="{out_index}"/>', "    </Outputs>",
              "    <InitialUnknowns>", f'      <Unknown index="{out_index}"/>',
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


# ----------------------------------------------------------------------------- C
_TLS = """#if defined(_MSC_VER)
#define HYST_TLS __declspec(thread)
#elif defined(__STDC_VERSION__) && __STDC_VERSION__ >= 201112L
#define HYST_TLS _Thread_local
#else
#define HYST_TLS __thread
#endif"""

# The instance, shared by both FMI versions (HX: the model identifier). Each entry point
# that runs the model first points HX_P_ (thread-local) at the instance's constants.
_CORE = r"""
typedef struct {
    HX_params P;               /* stage constants, derived from mp */
    double mp[HX_NMP];         /* model parameters, by value reference - HX_VR0 */
    HX_m_state st;             /* memory of the model */
    double u, y, time;
    int mode;                  /* 0 instantiated, 1 initialisation, 2 stepping, 3 terminated */
    int dirty;                 /* parameters changed since the constants were derived */
    char name[128];
    HX_LOGGER
} HX_inst;

#define HX_NOT_FINITE "these parameters make the model's coefficients non-finite (a zero " \
    "width or frequency, an overflow)"

/* whether every derived constant is finite */
static int HX_finite(void)
{
    unsigned i = 0u;
    (void)i;
HX_FINITE_BODY
    return 1;
}

static void HX_tune(const double *mp)
{
    unsigned i = 0u, j = 0u;
    (void)i; (void)j; (void)mp;
HX_TUNE_BODY
}

static void HX_defaults(HX_inst *s)
{
    s->P = HX_DEFAULTS;
    memcpy(s->mp, HX_MP0, sizeof s->mp);
    s->u = 0.0; s->y = 0.0; s->time = 0.0;
    s->mode = 0; s->dirty = 0;
    HX_P_ = &s->P;
    HX_m_init(&s->st);
}

static void HX_retune(HX_inst *s)
{
    HX_P_ = &s->P;
    if (s->dirty) { HX_tune(s->mp); s->dirty = 0; }
}

/* the output for the current input without advancing the memory */
static double HX_peek(HX_inst *s)
{
    HX_m_state copy = s->st;
    HX_P_ = &s->P;
    return HX_m_step(&copy, s->u);
}

static int HX_get(HX_inst *s, unsigned vr, double *v)
{
    if (vr == 0u) *v = s->time;
    else if (vr == 1u) *v = s->u;
    else if (vr == 2u) *v = s->y;
    else if (vr == 3u && HX_DT > 0.0) *v = HX_DT;
    else if (vr == 4u && HX_HAS_PREVIEW) *v = (double)HX_PREVIEW;
    else if (vr >= HX_VR0 && vr < HX_VR0 + HX_NPAR) *v = s->mp[vr - HX_VR0];
    else return 0;
    return 1;
}

/* 0: done; else a message for the user */
static const char *HX_set(HX_inst *s, unsigned vr, double v)
{
    if (vr == 1u) { s->u = v; return 0; }
    if (vr >= HX_VR0 && vr < HX_VR0 + HX_NPAR) {
        const unsigned k = vr - HX_VR0;
        if (HX_KIND[k] == 0)
            return "this parameter is fixed at export; re-export the FMU to change it";
        if (HX_KIND[k] == 2 && s->mode >= 2)
            return "an initial-state parameter can only be set before initialisation "
                   "(or after a reset)";
        if (!(v == v) || v - v != 0.0) return "parameter values must be finite";
        {
            const double old = s->mp[k];
            s->mp[k] = v;
            s->dirty = 1;
            if (s->mode >= 2) {
                HX_retune(s);
                if (!HX_finite()) {
                    s->mp[k] = old;
                    s->dirty = 1;
                    HX_retune(s);
                    return HX_NOT_FINITE "; the previous value is kept";
                }
            }
        }
        return 0;
    }
    if (vr <= 4u) return "this variable cannot be set";
    return "unknown value reference";
}

/* 0, or a message when the parameters set before initialisation are unusable */
static const char *HX_start(HX_inst *s)
{
    HX_retune(s);
    if (!HX_finite()) return HX_NOT_FINITE;
    HX_m_init(&s->st);
    s->y = HX_peek(s);
    s->mode = 2;
    return 0;
}

/* run the samples of one communication step; 0 or a message */
static const char *HX_step(HX_inst *s, double h)
{
    long n = 1, k;
    if (HX_DT > 0.0) {
        const double r = h / HX_DT;
        n = (long)floor(r + 0.5);
        if (n < 1 || fabs(r - (double)n) > 1e-6 * r)
            return "the communication step must be a whole number (>= 1) of sample times "
                   "(sample_time)";
    }
    HX_retune(s);
    for (k = 0; k < n; ++k) s->y = HX_m_step(&s->st, s->u);
    s->time += h;
    return 0;
}
"""

_FMI3 = r"""
#define HX_LOGGER fmi3InstanceEnvironment env; fmi3LogMessageCallback log; int logging;
#include "fmi3Functions.h"
HX_CORE_HERE

static void HX_msg(HX_inst *s, fmi3Status st, const char *what)
{
    if (s->log) s->log(s->env, st, "logStatusError", what);
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn,
                               size_t nCategories, const fmi3String categories[])
{
    (void)nCategories; (void)categories;
    if (!instance) return fmi3Error;
    ((HX_inst *)instance)->logging = loggingOn ? 1 : 0;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
    fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
    fmi3InstanceEnvironment instanceEnvironment, fmi3LogMessageCallback logMessage)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible;
    (void)loggingOn;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                               "this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName,
    fmi3String instantiationToken, fmi3String resourcePath, fmi3Boolean visible,
    fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instanceName; (void)instantiationToken; (void)resourcePath; (void)visible;
    (void)loggingOn; (void)clockUpdate; (void)lockPreemption; (void)unlockPreemption;
    if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                               "this FMU supports co-simulation only");
    return NULL;
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
    fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
    fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
    const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    HX_inst *s;
    (void)resourcePath; (void)visible; (void)eventModeUsed; (void)earlyReturnAllowed;
    (void)requiredIntermediateVariables; (void)nRequiredIntermediateVariables;
    (void)intermediateUpdate;
    if (!instantiationToken || strcmp(instantiationToken, HX_TOKEN) != 0) {
        if (logMessage) logMessage(instanceEnvironment, fmi3Error, "logStatusError",
            "instantiation token does not match modelDescription.xml (a different FMU?)");
        return NULL;
    }
    s = (HX_inst *)calloc(1, sizeof *s);
    if (!s) return NULL;
    strncpy(s->name, instanceName ? instanceName : "", sizeof s->name - 1);
    s->env = instanceEnvironment;
    s->log = logMessage;
    s->logging = loggingOn ? 1 : 0;
    HX_defaults(s);
    return s;
}

void fmi3FreeInstance(fmi3Instance instance) { free(instance); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
    fmi3Float64 tolerance, fmi3Float64 startTime, fmi3Boolean stopTimeDefined,
    fmi3Float64 stopTime)
{
    HX_inst *s = (HX_inst *)instance;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (!s) return fmi3Error;
    s->time = startTime;
    s->mode = 1;
    return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    const char *err;
    if (!instance) return fmi3Error;
    err = HX_start((HX_inst *)instance);
    if (err) { HX_msg((HX_inst *)instance, fmi3Error, err); return fmi3Error; }
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) { return instance ? fmi3OK : fmi3Error; }

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    ((HX_inst *)instance)->mode = 3;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    if (!instance) return fmi3Error;
    HX_defaults((HX_inst *)instance);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
    size_t nValueReferences, fmi3Float64 values[], size_t nValues)
{
    HX_inst *s = (HX_inst *)instance;
    size_t k;
    if (!s || nValues != nValueReferences) return fmi3Error;
    for (k = 0; k < nValueReferences; ++k) {
        if (!HX_get(s, valueReferences[k], &values[k])) {
            HX_msg(s, fmi3Error, "fmi3GetFloat64: unknown value reference");
            return fmi3Error;
        }
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
    size_t nValueReferences, const fmi3Float64 values[], size_t nValues)
{
    HX_inst *s = (HX_inst *)instance;
    size_t k;
    if (!s || nValues != nValueReferences) return fmi3Error;
    for (k = 0; k < nValueReferences; ++k) {
        const char *err = HX_set(s, valueReferences[k], values[k]);
        if (err) { HX_msg(s, fmi3Error, err); return fmi3Error; }
    }
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
    fmi3Float64 communicationStepSize, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
    fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
    fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    HX_inst *s = (HX_inst *)instance;
    const char *err;
    (void)noSetFMUStatePriorToCurrentPoint;
    if (!s || s->mode != 2) return fmi3Error;
    if (eventHandlingNeeded) *eventHandlingNeeded = fmi3False;
    if (terminateSimulation) *terminateSimulation = fmi3False;
    if (earlyReturn) *earlyReturn = fmi3False;
    s->time = currentCommunicationPoint;
    err = HX_step(s, communicationStepSize);
    if (lastSuccessfulTime) *lastSuccessfulTime = s->time;
    if (err) { HX_msg(s, fmi3Error, err); return fmi3Error; }
    return fmi3OK;
}
"""

_FMI2 = r"""
#define HX_LOGGER const fmi2CallbackFunctions *cb; int logging;
#include "fmi2Functions.h"
HX_CORE_HERE

static void HX_msg(HX_inst *s, fmi2Status st, const char *what)
{
    if (s->cb && s->cb->logger)
        s->cb->logger(s->cb->componentEnvironment, s->name, st, "logStatusError", "%s", what);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    (void)nCategories; (void)categories;
    if (!c) return fmi2Error;
    ((HX_inst *)c)->logging = loggingOn ? 1 : 0;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
    fmi2String fmuResourceLocation, const fmi2CallbackFunctions *functions,
    fmi2Boolean visible, fmi2Boolean loggingOn)
{
    HX_inst *s;
    (void)fmuResourceLocation; (void)visible;
    if (fmuType != fmi2CoSimulation || !fmuGUID || strcmp(fmuGUID, HX_TOKEN) != 0) {
        if (functions && functions->logger)
            functions->logger(functions->componentEnvironment, instanceName, fmi2Error,
                "logStatusError", "%s", fmuType != fmi2CoSimulation
                ? "this FMU supports co-simulation only"
                : "GUID does not match modelDescription.xml (a different FMU?)");
        return NULL;
    }
    s = (HX_inst *)calloc(1, sizeof *s);
    if (!s) return NULL;
    strncpy(s->name, instanceName ? instanceName : "", sizeof s->name - 1);
    s->cb = functions;
    s->logging = loggingOn ? 1 : 0;
    HX_defaults(s);
    return s;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined,
    fmi2Real tolerance, fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    HX_inst *s = (HX_inst *)c;
    (void)toleranceDefined; (void)tolerance; (void)stopTimeDefined; (void)stopTime;
    if (!s) return fmi2Error;
    s->time = startTime;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    if (!c) return fmi2Error;
    ((HX_inst *)c)->mode = 1;
    return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    const char *err;
    if (!c) return fmi2Error;
    err = HX_start((HX_inst *)c);
    if (err) { HX_msg((HX_inst *)c, fmi2Error, err); return fmi2Error; }
    return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    if (!c) return fmi2Error;
    ((HX_inst *)c)->mode = 3;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c)
{
    if (!c) return fmi2Error;
    HX_defaults((HX_inst *)c);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    HX_inst *s = (HX_inst *)c;
    size_t k;
    if (!s) return fmi2Error;
    for (k = 0; k < nvr; ++k) {
        if (vr[k] == 0u || !HX_get(s, vr[k], &value[k])) {
            HX_msg(s, fmi2Error, "fmi2GetReal: unknown value reference");
            return fmi2Error;
        }
    }
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    HX_inst *s = (HX_inst *)c;
    size_t k;
    if (!s) return fmi2Error;
    for (k = 0; k < nvr; ++k) {
        const char *err = vr[k] == 0u ? "unknown value reference" : HX_set(s, vr[k], value[k]);
        if (err) { HX_msg(s, fmi2Error, err); return fmi2Error; }
    }
    return fmi2OK;
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
    fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentCommunicationPoint)
{
    HX_inst *s = (HX_inst *)c;
    const char *err;
    (void)noSetFMUStatePriorToCurrentCommunicationPoint;
    if (!s || s->mode != 2) return fmi2Error;
    s->time = currentCommunicationPoint;
    err = HX_step(s, communicationStepSize);
    if (err) { HX_msg(s, fmi2Error, err); return fmi2Error; }
    return fmi2OK;
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    (void)s;
    if (!c || !value) return fmi2Error;
    *value = fmi2OK;
    return fmi2OK;
}
"""

_IMPLEMENTED = {
    3: {"fmi3GetVersion", "fmi3SetDebugLogging", "fmi3InstantiateModelExchange",
        "fmi3InstantiateCoSimulation", "fmi3InstantiateScheduledExecution", "fmi3FreeInstance",
        "fmi3EnterInitializationMode", "fmi3ExitInitializationMode", "fmi3EnterStepMode",
        "fmi3Terminate", "fmi3Reset", "fmi3GetFloat64", "fmi3SetFloat64", "fmi3DoStep"},
    2: {"fmi2GetTypesPlatform", "fmi2GetVersion", "fmi2SetDebugLogging", "fmi2Instantiate",
        "fmi2FreeInstance", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
        "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset", "fmi2GetReal",
        "fmi2SetReal", "fmi2DoStep", "fmi2GetStatus"},
}
_TYPEDEF = re.compile(r"typedef\s+(fmi[23]Status)\s+(fmi[23]\w+)TYPE\s*\(([^)]*)\)\s*;")
_IDENT = re.compile(r"[A-Za-z_]\w*")


def _stubs(version: int) -> list[str]:
    """A definition returning ``fmi<v>Error`` for every status function of the FMI headers
    that this FMU does not provide (the prototypes are read from the headers)."""
    text = (fmi_headers(version) / f"fmi{version}FunctionTypes.h").read_text(errors="replace")
    text = re.sub(r"/\*.*?\*/", " ", text, flags=re.DOTALL)
    text = re.sub(r"//[^\n]*", " ", text)
    out = []
    for status, fn, params in _TYPEDEF.findall(text):
        if fn in _IMPLEMENTED[version]:
            continue
        decls, names = [], []
        plist = [p.strip() for p in " ".join(params.split()).split(",")]
        for i, p in enumerate(plist):
            if p in ("", "void"):
                continue
            idents = [t for t in _IDENT.findall(p) if t not in ("const", "struct", "unsigned")]
            if len(idents) < 2:  # unnamed parameter: name it
                p = p.replace("[]", f" p{i}[]") if "[]" in p else f"{p} p{i}"
                idents.append(f"p{i}")
            decls.append(p)
            names.append(idents[-1])
        body = " ".join(f"(void){n};" for n in names)
        out.append(f"{status} {fn}({', '.join(decls) or 'void'})\n"
                   f"{{ {body} return {status[:4]}Error; }}")
    return out


def _c_source(ident: str, version: int, header: str, body: str, struct: list[str],
              defaults: list[str], tune: list[str], mp0: list[float], kinds: list[int],
              nmp: int, dt: float | None, preview: int, inverse: bool,
              finite: list[str]) -> str:
    hx = ident
    core = _CORE.replace("HX_TUNE_BODY", "\n".join(f"    {line}" for line in tune)).replace(
        "HX_FINITE_BODY", "\n".join(finite))
    wrapper = (_FMI3 if version == 3 else _FMI2).replace("HX_CORE_HERE", core)
    mp_init = ", ".join(c_double(v) for v in mp0) or "0.0"
    kind_init = ", ".join(str(k) for k in kinds) or "0"
    lines = [
        f"/* {ident}.c: FMI {version}.0 co-simulation FMU generated by hysteresis-explorer",
        " * (core/export_fmu.py) from the C99 code of core/export_c.py. One translation unit;",
        f" * build: cc -std=c99 -O2 -shared -fPIC -I<FMI {version} headers> {ident}.c -lm */",
        "#include <math.h>",
        "#include <stddef.h>",
        "#include <stdlib.h>",
        "#include <string.h>",
        "",
        _TLS,
        "",
        f'#define {hx}_TOKEN "@TOKEN@"',
        f"#define {hx}_DT {c_double(dt) if dt is not None else '0.0'}",
        f"#define {hx}_PREVIEW {preview}",
        f"#define {hx}_HAS_PREVIEW {1 if inverse else 0}",
        f"#define {hx}_VR0 {FIRST_PARAMETER_VR}u",
        f"#define {hx}_NPAR {len(mp0)}u",
        f"#define {hx}_NMP {nmp}",
        "",
        "/* every constant of every stage: the run-time (tunable) copy of the C export's",
        " * static constants; the model code reads them through the thread-local pointer */",
        "typedef struct {", *struct, f"}} {hx}_params;",
        f"static const {hx}_params {hx}_DEFAULTS = {{", *defaults, "};",
        f"static HYST_TLS {hx}_params *{hx}_P_;",
        f"/* model parameters (value reference {FIRST_PARAMETER_VR} + index), their kinds: "
        "1 tunable, 2 initial state (fixed), 0 fixed at export */",
        f"static const double {hx}_MP0[{nmp}] = {{{mp_init}}};",
        f"static const unsigned char {hx}_KIND[{nmp}] = {{{kind_init}}};",
        "",
        header,
        "",
        body,
        "",
        wrapper.replace("HX", hx),
        "",
        "/* ---- the rest of the FMI API: not provided by this co-simulation FMU */",
        *_stubs(version),
        "",
    ]
    return "\n".join(lines)



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
