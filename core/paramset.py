"""Versioned parameter sets: the JSON document that carries a model out of this tool.

A parameter set wraps a model's :meth:`~core.base.Model.to_dict` form with a format tag, a
version number, physical units and provenance (when and how it was made, fit metrics)::

    {
      "format": "hysteresis-explorer/parameter-set",
      "version": 1,
      "model": {"type": "pi", "p0": 0.72, "thresholds": [0.45, 0.9], "weights": [0.6, 0.48]},
      "units": {"input": "V", "output": "um", "time": "s"},
      "provenance": {"created": "2026-01-01T12:00:00+00:00", "tool": "hysteresis-explorer 0.1.0",
                     "source": "paper 001, Example 1", "fit": null, "notes": null}
    }

Loading validates the whole document and reports the first problem with its JSON path
(``model.weights[3]: must be a number, got "abc"``). See ``docs/pages/parameter-set.md``.
"""

from __future__ import annotations

import copy
import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from types import MappingProxyType
from typing import Any

from .base import Chain, Model, model_class, model_from_dict, registered_types
from .exceptions import NotInvertibleError, ParameterError

__all__ = [
    "FORMAT",
    "SUPPORTED_VERSIONS",
    "VERSION",
    "ParameterSet",
    "ParameterSetError",
    "Provenance",
    "Units",
    "clean_unit",
    "ensure_model_types_registered",
    "load_parameter_set",
    "model_from_document",
    "tool_name",
    "unit_problem",
]

#: Value of the ``"format"`` field of every parameter-set document.
FORMAT = "hysteresis-explorer/parameter-set"
#: Version written by :meth:`ParameterSet.to_dict`.
VERSION = 1
#: Versions :func:`load_parameter_set` understands.
SUPPORTED_VERSIONS: tuple[int, ...] = (1,)

_TOP_KEYS = ("format", "version", "model", "units", "provenance")
_UNIT_KEYS = ("input", "output", "time")
_PROVENANCE_KEYS = ("created", "tool", "source", "fit", "notes")
#: Longest unit accepted (characters).
UNIT_MAX_LENGTH = 32
#: Characters a unit may hold besides letters and digits (any script: ``µ``, ``Ω``, ``²``).
UNIT_SYMBOLS = " /*^-.%°·"

class ParameterSetError(ParameterError):
    """A parameter-set document is malformed; the message starts with the JSON path."""


def unit_problem(text: str) -> str | None:
    """What makes ``text`` not a unit, or ``None`` when it is one.

    The unit grammar: letters and digits of any script (``µm``, ``Ω``, ``m²``), the
    symbols of :data:`UNIT_SYMBOLS` (``/ * ^ - . % ° ·`` and spaces), at most
    :data:`UNIT_MAX_LENGTH` characters; ``""`` (no unit) is allowed. A parameter set is
    shared as a file and its units reach generated C, FMU descriptions and reports, so
    anything else (quotes, braces, semicolons, backslashes, control characters) is refused.

    Parameters
    ----------
    text : str

    Returns
    -------
    str or None
        A sentence for the user, or ``None``.
    """
    if len(text) > UNIT_MAX_LENGTH:
        return f"is {len(text)} characters long; a unit has at most {UNIT_MAX_LENGTH}"
    bad = sorted({c for c in text if not (c.isalnum() or c in UNIT_SYMBOLS)})
    if bad:
        shown = ", ".join(repr(c) if c.isprintable() else f"U+{ord(c):04X}" for c in bad[:5])
        return (f"has characters a unit cannot hold ({shown}); a unit is letters, digits, "
                "spaces and / * ^ - . % °, e.g. \"um\", \"V\", \"N/mm^2\"")
    return None


def clean_unit(text: str) -> str:
    """``text`` when it is a unit (see :func:`unit_problem`), else ``""`` (unknown unit).

    For units read from a recording's column headers, which are the user's data but not
    always units; a parameter set loaded from a file is refused instead.
    """
    return text if unit_problem(text) is None else ""


def tool_name() -> str:
    """``"hysteresis-explorer <version>"`` of the installed package (``0.1.0`` if unknown)."""
    try:
        from importlib.metadata import PackageNotFoundError, version

        try:
            v = version("hysteresis-explorer")
        except PackageNotFoundError:
            v = "0.1.0"
    except ImportError:  # pragma: no cover - stdlib always has it on 3.11
        v = "0.1.0"
    return f"hysteresis-explorer {v}"


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _jtype(v: object) -> str:
    """JSON name of a Python value's type, for messages."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, int | float):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, list | tuple):
        return "an array"
    if isinstance(v, Mapping):
        return "an object"
    return type(v).__name__


def _show(v: object) -> str:
    try:
        s = json.dumps(v)
    except (TypeError, ValueError):
        s = repr(v)
    return s if len(s) <= 40 else s[:37] + "..."


def _is_number(v: object) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _check_number(v: object, path: str) -> None:
    if not isinstance(v, int | float) or isinstance(v, bool):  # not _is_number(v)
        raise ParameterSetError(f"{path}: must be a number, got {_jtype(v)} {_show(v)}")
    if not math.isfinite(v):
        raise ParameterSetError(f"{path}: must be a finite number, got {v!r}")


def _check_numbers(v: object, path: str) -> None:
    if not isinstance(v, list | tuple):
        raise ParameterSetError(f"{path}: must be an array of numbers, got {_jtype(v)} {_show(v)}")
    if not v:
        raise ParameterSetError(f"{path}: must not be empty")
    for i, x in enumerate(v):
        _check_number(x, f"{path}[{i}]")


def _check_matrix(v: object, path: str) -> None:
    """A non-empty array of equal-length, non-empty arrays of finite numbers (row by row)."""
    if not isinstance(v, list | tuple):
        raise ParameterSetError(
            f"{path}: must be an array of rows (arrays of numbers), got {_jtype(v)} {_show(v)}"
        )
    if not v:
        raise ParameterSetError(f"{path}: must not be empty")
    for i, row in enumerate(v):
        _check_numbers(row, f"{path}[{i}]")
        if len(row) != len(v[0]):
            raise ParameterSetError(
                f"{path}[{i}]: has {len(row)} number(s) but {path}[0] has {len(v[0])}; "
                "every row must have the same length"
            )


@dataclass(frozen=True)
class Units:
    """Physical units of a parameter set (free text, e.g. ``"V"``, ``"um"``, ``"s"``).

    Attributes
    ----------
    input : str
        Unit of the model input (the actuator drive, e.g. volts).
    output : str
        Unit of the model output (e.g. micrometres).
    time : str
        Unit of the time axis; dynamic models (``lti``) use seconds.
    """

    input: str = "V"
    output: str = "um"
    time: str = "s"

    def __post_init__(self) -> None:
        for k in _UNIT_KEYS:
            v = getattr(self, k)
            if not isinstance(v, str):
                raise ParameterSetError(f"units.{k}: must be a string, got {_jtype(v)} {_show(v)}")
            problem = unit_problem(v)
            if problem is not None:
                raise ParameterSetError(f"units.{k}: {problem}")

    def swapped(self) -> Units:
        """Units of the inverse model: input and output exchanged."""
        return Units(input=self.output, output=self.input, time=self.time)

    def to_dict(self) -> dict[str, str]:
        """``{"input": ..., "output": ..., "time": ...}``."""
        return {"input": self.input, "output": self.output, "time": self.time}

    @classmethod
    def from_dict(cls, d: object, path: str = "units") -> Units:
        """Validate and build; unknown keys and non-string values are errors."""
        if not isinstance(d, Mapping):
            raise ParameterSetError(f"{path}: must be an object, got {_jtype(d)}")
        extra = sorted(set(d) - set(_UNIT_KEYS))
        if extra:
            raise ParameterSetError(
                f"{path}.{extra[0]}: unknown unit key; allowed keys: {', '.join(_UNIT_KEYS)}"
            )
        for k, v in d.items():
            if not isinstance(v, str):
                raise ParameterSetError(f"{path}.{k}: must be a string, got {_jtype(v)} {_show(v)}")
        return cls(**{k: d[k] for k in _UNIT_KEYS if k in d})


@dataclass(frozen=True)
class Provenance:
    """Where a parameter set came from.

    Attributes
    ----------
    created : str
        ISO 8601 creation time (UTC).
    tool : str
        ``"hysteresis-explorer <version>"``.
    source : str or None
        What the parameters were made from: data files, a paper example, ``"inverse of ..."``.
    fit : mapping or None
        Fit report (``FitReport.to_dict()``: metrics such as RMSE, options used), JSON-ready.
    notes : str or None
        Free text.
    extra : mapping
        Any further provenance keys found in a document, kept verbatim.
    """

    created: str = field(default_factory=_now)
    tool: str = field(default_factory=tool_name)
    source: str | None = None
    fit: Mapping[str, Any] | None = None
    notes: str | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for k in ("created", "tool"):
            if not isinstance(getattr(self, k), str):
                raise ParameterSetError(f"provenance.{k}: must be a string")
        for k in ("source", "notes"):
            v = getattr(self, k)
            if v is not None and not isinstance(v, str):
                raise ParameterSetError(
                    f"provenance.{k}: must be a string or null, got {_jtype(v)} {_show(v)}"
                )
        if self.fit is not None:
            if not isinstance(self.fit, Mapping):
                raise ParameterSetError(
                    f"provenance.fit: must be an object or null, got {_jtype(self.fit)}"
                )
            fit = _json_ready(self.fit, "provenance.fit")
            object.__setattr__(self, "fit", MappingProxyType(fit))
        extra = _json_ready(dict(self.extra), "provenance")
        object.__setattr__(self, "extra", MappingProxyType(extra))

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled as its fields (a read-only mapping does not pickle), so a parameter set
        and a fit's outcome travel between processes (a job's worker and the server)."""
        return (Provenance, (self.created, self.tool, self.source,
                             None if self.fit is None else dict(self.fit), self.notes,
                             dict(self.extra)))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready mapping (``fit`` deep-copied)."""
        d: dict[str, Any] = {
            "created": self.created,
            "tool": self.tool,
            "source": self.source,
            "fit": None if self.fit is None else copy.deepcopy(dict(self.fit)),
            "notes": self.notes,
        }
        for k, v in self.extra.items():
            d.setdefault(k, copy.deepcopy(v))
        return d

    @classmethod
    def from_dict(cls, d: object, path: str = "provenance") -> Provenance:
        """Validate and build; missing keys get defaults, unknown keys go to ``extra``."""
        if not isinstance(d, Mapping):
            raise ParameterSetError(f"{path}: must be an object, got {_jtype(d)}")
        kw = {k: d[k] for k in _PROVENANCE_KEYS if k in d}
        extra = {k: v for k, v in d.items() if k not in _PROVENANCE_KEYS}
        return cls(**kw, extra=extra)


def _json_ready(obj: Any, path: str) -> Any:
    """Deep copy of ``obj`` as plain JSON types (numpy scalars/arrays converted)."""
    import numpy as np

    if isinstance(obj, np.ndarray):
        obj = obj.tolist()
    elif isinstance(obj, np.generic):
        obj = obj.item()
    if obj is None or isinstance(obj, bool | str):
        return obj
    if isinstance(obj, int | float):
        if isinstance(obj, float) and not math.isfinite(obj):
            return None  # JSON has no NaN/inf; an undefined metric is null
        return obj
    if isinstance(obj, Mapping):
        return {str(k): _json_ready(v, f"{path}.{k}") for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_json_ready(v, f"{path}[{i}]") for i, v in enumerate(obj)]
    raise ParameterSetError(f"{path}: {type(obj).__name__} is not JSON-serialisable")


# ----------------------------------------------------------------------------- model checks
def _check_generic(v: object, path: str) -> None:
    """Finite numbers everywhere; arrays either all numbers or all non-numbers."""
    if _is_number(v):
        _check_number(v, path)
    elif isinstance(v, list | tuple):
        nums = [_is_number(x) for x in v]
        if any(nums) and not all(nums):
            i = nums.index(False)
            raise ParameterSetError(
                f"{path}[{i}]: must be a number, got {_jtype(v[i])} {_show(v[i])}"
            )
        for i, x in enumerate(v):
            _check_generic(x, f"{path}[{i}]")
    elif isinstance(v, Mapping):
        if "type" in v:
            _check_model_tree(v, path)
        else:
            for k, x in v.items():
                _check_generic(x, f"{path}.{k}")


def ensure_model_types_registered() -> list[str]:
    """The registered model types (importing :mod:`core` imports every model module, through
    :mod:`core.models`)."""
    return registered_types()


def _check_model_tree(node: object, path: str) -> None:  # noqa: C901 - one check per field kind of a model document
    """Structural checks of a model node and everything nested in it (no construction)."""
    ensure_model_types_registered()
    if not isinstance(node, Mapping):
        raise ParameterSetError(f"{path}: must be an object describing a model, got {_jtype(node)}")
    known = registered_types()
    if "type" not in node:
        raise ParameterSetError(f"{path}.type: missing; known model types: {', '.join(known)}")
    t = node["type"]
    if not isinstance(t, str) or t not in known:
        raise ParameterSetError(
            f"{path}.type: unknown model type {_show(t)}; known model types: {', '.join(known)}"
        )
    fields = {f.name: f for f in model_class(t).fields}
    for key, f in fields.items():
        where = f"{path}.{key}"
        if key not in node or node[key] is None:
            if f.optional:
                continue
            raise ParameterSetError(f"{where}: missing (required by model type {t!r})")
        v = node[key]
        if f.kind == "number":
            _check_number(v, where)
        elif f.kind == "numbers":
            _check_numbers(v, where)
        elif f.kind == "matrix":
            _check_matrix(v, where)
        elif f.kind == "model":
            _check_model_tree(v, where)
        elif f.kind == "models":
            if not isinstance(v, list) or not v:
                raise ParameterSetError(f"{where}: must be a non-empty array of models")
            for i, s in enumerate(v):
                _check_model_tree(s, f"{where}[{i}]")
        else:
            _check_generic(v, where)
    for key in node:
        if key != "type" and key not in fields:
            raise ParameterSetError(
                f"{path}.{key}: unknown field of model type {t!r}; its fields: "
                f"{', '.join(fields) or '(none)'}"
            )


def _with_path(exc: Exception, node: Mapping[str, Any], path: str) -> str:
    """Prefix a model's own error message with the JSON path of the field it names."""
    msg = str(exc)
    keys = sorted((k for k in node if k != "type"), key=len, reverse=True)
    for k in keys:
        m = re.match(rf"{re.escape(k)}((?:\[\d+\])*)(?=[\s:=]|$)[:\s]*", msg)
        if m:
            head, rest = f"{path}.{k}{m.group(1) or ''}", msg[m.end():]
            return f"{head} {rest}" if rest.startswith("=") else f"{head}: {rest}"
    return f"{path}: {msg}"


def _build_model(node: Mapping[str, Any], path: str) -> Model:
    """Construct a (pre-checked) model node, re-raising errors with their JSON path."""
    if node["type"] == "chain":
        stages = tuple(
            _build_model(s, f"{path}.stages[{i}]") for i, s in enumerate(node["stages"])
        )
        return Chain(stages)
    for key, v in node.items():  # nested models first, so their errors carry their path
        if key != "type" and isinstance(v, Mapping) and "type" in v:
            _build_model(v, f"{path}.{key}")
    try:
        return model_from_dict(dict(node))
    except ParameterError as exc:
        raise ParameterSetError(_with_path(exc, node, path)) from exc


def model_from_document(node: object, path: str = "model") -> Model:
    """Validate a model's JSON form and build it; errors name the JSON path.

    Parameters
    ----------
    node : object
        Parsed JSON of a model (``Model.to_dict()`` form).
    path : str
        JSON path used in messages.

    Returns
    -------
    Model

    Raises
    ------
    ParameterSetError
        With the JSON path of the first problem.
    """
    _check_model_tree(node, path)
    assert isinstance(node, Mapping)  # _check_model_tree said so
    return _build_model(node, path)


# ----------------------------------------------------------------------------- the document
@dataclass(frozen=True, eq=False)
class ParameterSet:
    """A model with units and provenance: the unit of exchange of this tool.

    Parameters
    ----------
    model : Model
        Any registered model (``pi``, ``chain``, ``deadzone``, ...).
    units : Units, optional
        Physical units; ``V`` → ``um`` over ``s`` by default.
    provenance : Provenance, optional
        Creation time, tool version, source, fit metrics, notes.

    Examples
    --------
    >>> from core.pi import PIModel
    >>> ps = ParameterSet(PIModel(0.72, [0.45, 0.9], [0.6, 0.48]))
    >>> load_parameter_set(ps.to_json()).model.slopes.tolist()
    [0.72, 1.32, 1.8]
    """

    model: Model
    units: Units = field(default_factory=Units)
    provenance: Provenance = field(default_factory=Provenance)

    def __post_init__(self) -> None:
        if not isinstance(self.model, Model):
            raise ParameterSetError(
                f"model: must be a core Model instance, got {type(self.model).__name__}"
            )
        if isinstance(self.units, Mapping):
            object.__setattr__(self, "units", Units.from_dict(self.units))
        if isinstance(self.provenance, Mapping):
            object.__setattr__(self, "provenance", Provenance.from_dict(self.provenance))

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_model(
        cls,
        model: Model,
        *,
        units: Units | Mapping[str, str] | None = None,
        source: str | None = None,
        fit: Mapping[str, Any] | None = None,
        notes: str | None = None,
    ) -> ParameterSet:
        """Wrap a model with fresh provenance (now, this tool's version).

        Parameters
        ----------
        model : Model
        units : Units or mapping, optional
            Defaults to ``Units()`` (V, um, s).
        source, notes : str, optional
        fit : mapping, optional
            JSON-ready fit report, e.g. ``FitReport.to_dict()``.
        """
        if units is None:
            units = Units()
        elif isinstance(units, Mapping):
            units = Units.from_dict(units)
        return cls(model, units, Provenance(source=source, fit=fit, notes=notes))

    @classmethod
    def from_dict(cls, doc: object, *, require_inverse: bool = False) -> ParameterSet:
        """Validate a parsed document and build the parameter set.

        Parameters
        ----------
        doc : object
            Parsed JSON.
        require_inverse : bool
            Also check that the model has an inverse (``NotInvertibleError`` otherwise).

        Raises
        ------
        ParameterSetError
            If the document is malformed; the message starts with the JSON path.
        NotInvertibleError
            If ``require_inverse`` and the model is not invertible.
        """
        if not isinstance(doc, Mapping):
            raise ParameterSetError(
                f"(document): a parameter set must be a JSON object, got {_jtype(doc)}"
            )
        if "format" not in doc:
            hint = ""
            if "type" in doc:
                hint = (
                    '; this looks like a bare model (it has "type"): wrap it as '
                    f'{{"format": "{FORMAT}", "version": {VERSION}, "model": {{...}}}}'
                )
            raise ParameterSetError(f'format: missing; expected "{FORMAT}"{hint}')
        if doc["format"] != FORMAT:
            raise ParameterSetError(
                f'format: {_show(doc["format"])} is not a parameter set; expected "{FORMAT}"'
            )
        supported = ", ".join(str(v) for v in SUPPORTED_VERSIONS)
        if "version" not in doc:
            raise ParameterSetError(f"version: missing; supported versions: {supported}")
        ver = doc["version"]
        if not _is_number(ver) or ver not in SUPPORTED_VERSIONS:
            raise ParameterSetError(
                f"version: unsupported version {_show(ver)}; this tool reads version(s) "
                f"{supported} (upgrade hysteresis-explorer to read newer documents)"
            )
        unknown = sorted(set(doc) - set(_TOP_KEYS))
        if unknown:
            raise ParameterSetError(
                f"{unknown[0]}: unknown top-level field; allowed fields: {', '.join(_TOP_KEYS)}"
            )
        if "model" not in doc:
            raise ParameterSetError("model: missing; a parameter set needs a model object")
        model = model_from_document(doc["model"], "model")
        units = Units.from_dict(doc.get("units", {}))
        prov = Provenance.from_dict(doc.get("provenance", {}))
        ps = cls(model, units, prov)
        if require_inverse:
            ps.check_invertible()
        return ps

    @classmethod
    def from_json(cls, text: str, *, require_inverse: bool = False) -> ParameterSet:
        """Parse and validate a JSON string (NaN/Infinity literals are rejected)."""
        return cls.from_dict(_parse_json(text, "<string>"), require_inverse=require_inverse)

    @classmethod
    def load(cls, path: str | Path, *, require_inverse: bool = False) -> ParameterSet:
        """Read, parse and validate a parameter-set file."""
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise FileNotFoundError(f"parameter-set file not found: {p}") from None
        try:
            return cls.from_dict(_parse_json(text, str(p)), require_inverse=require_inverse)
        except ParameterSetError as exc:
            raise ParameterSetError(f"{p}: {exc}") from exc

    # ------------------------------------------------------------------ export
    def to_dict(self) -> dict[str, Any]:
        """The JSON document as plain Python objects."""
        return {
            "format": FORMAT,
            "version": VERSION,
            "model": _json_ready(self.model.to_dict(), "model"),
            "units": self.units.to_dict(),
            "provenance": self.provenance.to_dict(),
        }

    def to_json(self, indent: int | None = 2) -> str:
        """The JSON document as text (floats written with full round-trip precision)."""
        return json.dumps(self.to_dict(), indent=indent, allow_nan=False)

    def save(self, path: str | Path) -> Path:
        """Write :meth:`to_json` to ``path`` (parent directories are created).

        Returns
        -------
        Path
            The path written.
        """
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(self.to_json() + "\n", encoding="utf-8")
        return p

    # ------------------------------------------------------------------ derived sets
    def check_invertible(self) -> Model:
        """Return the inverse model or raise ``NotInvertibleError`` naming the reason."""
        try:
            return self.model.inverse()
        except NotInvertibleError as exc:
            raise NotInvertibleError(
                f"model: not invertible ({self.model.to_dict().get('type')}): {exc}"
            ) from exc

    def inverse(self, *, notes: str | None = None) -> ParameterSet:
        """The inverse compensator as a parameter set (units swapped, new provenance).

        Raises
        ------
        NotInvertibleError
            If the model has no inverse.
        """
        inv = self.check_invertible()
        src = self.provenance.source
        return ParameterSet(
            inv,
            self.units.swapped(),
            Provenance(
                source=f"inverse of {src}" if src else "inverse of a parameter set",
                notes=notes,
                extra={"inverse_of": self.to_dict()},
            ),
        )

    def with_provenance(self, **changes: Any) -> ParameterSet:
        """Copy with some provenance fields replaced (``source=``, ``notes=``, ``fit=``)."""
        return replace(self, provenance=replace(self.provenance, **changes))


def _parse_json(text: str, where: str) -> Any:
    def no_constants(name: str) -> Any:
        raise ParameterSetError(
            f"{where}: JSON contains {name}; every parameter must be a finite number"
        )

    try:
        return json.loads(text, parse_constant=no_constants)
    except json.JSONDecodeError as exc:
        raise ParameterSetError(
            f"{where}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from exc


def load_parameter_set(
    source: str | Path | Mapping[str, Any], *, require_inverse: bool = False
) -> ParameterSet:
    """Load and validate a parameter set from a file, a JSON string or a parsed dict.

    Parameters
    ----------
    source : str, Path or mapping
        A path, a JSON text (a string starting with ``{``) or the parsed document.
    require_inverse : bool
        Also check that the model is invertible.

    Returns
    -------
    ParameterSet

    Raises
    ------
    ParameterSetError
        Malformed document: the message names the JSON path (``model.weights[3]: ...``).
    NotInvertibleError
        ``require_inverse`` and the model has no inverse.
    FileNotFoundError
        ``source`` is a path that does not exist.
    """
    if isinstance(source, Mapping):
        return ParameterSet.from_dict(source, require_inverse=require_inverse)
    if isinstance(source, str) and source.lstrip().startswith("{"):
        return ParameterSet.from_json(source, require_inverse=require_inverse)
    if isinstance(source, str | Path):
        return ParameterSet.load(source, require_inverse=require_inverse)
    raise TypeError(f"cannot load a parameter set from {type(source).__name__}")
