"""Frozen dataclasses of the core as a versioned JSON document and back, exactly: the
JSON round trip of :meth:`DiagnosisResult.to_json
<core.diagnosis.results.DiagnosisResult.to_json>` / ``from_json`` (what a result holds:
its recordings, train/test rows, fits with structures, weights, models and predictions,
findings, round rows, base choice, adequacy verdict and every further field).

:meth:`DiagnosisResult.to_dict <core.diagnosis.results.DiagnosisResult.to_dict>` is the
*report* (``hyst diagnose --json``: derived numbers, no arrays); this writes the *object*,
so it can be stored and rebuilt later as the same object. The document is plain JSON (no
pickle: nothing stored is executed)::

    {"format": FORMAT, "version": N, "result": VALUE}

where a VALUE is JSON's own ``null``, booleans, numbers, strings, lists and objects (a
mapping with string keys not starting with ``$``), or one of the tagged objects

``{"$float": "nan" | "inf" | "-inf"}``
    A float JSON cannot write.
``{"$tuple": [VALUE, ...]}``
    A tuple (a list stays a list).
``{"$array": {"dtype": "<f8", "shape": [N, ...], "base64": "..."}}``
    A numeric or boolean numpy array, its bytes exactly (``dtype`` one of numpy's
    little-endian type strings); text arrays as ``{"dtype": "str", "items": [...]}``.
``{"$model": DOCUMENT}``
    A model of the model algebra (:meth:`core.base.Model.to_dict`, rebuilt with
    :func:`core.base.model_from_dict`).
``{"$type": NAME, "fields": {FIELD: VALUE, ...}}``
    A dataclass, one of the types the caller allows by name (no other class is built).

Reading checks the format, the version, every tag, every type name, the field names (an
unknown or a missing field is damage) and each field's value against its declared type;
a damaged document raises :class:`DocumentError` saying where.
"""

from __future__ import annotations

import base64
import binascii
import dataclasses
import math
import typing
from collections.abc import Mapping, Sequence
from types import MappingProxyType, NoneType, UnionType
from typing import Any

import numpy as np

from ..base import Model
from .structure import PIStageOutputs

__all__ = ["DocumentError", "read_document", "write_document"]

#: The numpy type strings an array may have (little-endian, or byte-order free).
_DTYPES = frozenset({"|b1", "<f8", "<f4", "<i8", "<i4", "|i1", "<i2", "|u1", "<u2", "<u4",
                     "<u8"})


class DocumentError(ValueError):
    """A document that is not one of its format (or an object that cannot be written).

    Parameters
    ----------
    where : str
        The place in the document (``result.baseline.pred[0]``).
    what : str
        What is wrong there.
    """

    def __init__(self, where: str, what: str) -> None:
        super().__init__(f"the stored diagnosis result is damaged at {where}: {what}; run "
                         "the diagnosis again")
        self.where = where
        self.what = what


class _Types:
    """The classes a document may name (``$type``), by name."""

    def __init__(self, types: Sequence[type]) -> None:
        self.by_name: Mapping[str, type] = MappingProxyType({c.__name__: c for c in types})


# ------------------------------------------------------------------------------ writing
def write_document(obj: Any, fmt: str, version: int, types: Sequence[type]
                   ) -> dict[str, Any]:
    """The JSON document of ``obj`` (see the module docstring), its dataclasses among
    ``types``.

    Raises
    ------
    DocumentError
        ``obj`` holds a value this format cannot write (names where).
    """
    return {"format": fmt, "version": version,
            "result": _encode(obj, "result", _Types(types))}


def _encode(x: Any, where: str, types: _Types) -> Any:
    if x is None or isinstance(x, bool | str):
        return x
    if isinstance(x, int | np.integer):
        return int(x)
    if isinstance(x, float | np.floating):
        v = float(x)
        if math.isfinite(v):
            return v
        return {"$float": "nan" if math.isnan(v) else "inf" if v > 0 else "-inf"}
    if isinstance(x, np.ndarray):
        return {"$array": _array_doc(x, where)}
    if isinstance(x, Model):
        return {"$model": x.to_dict()}
    if dataclasses.is_dataclass(x) and not isinstance(x, type):
        name = type(x).__name__
        if types.by_name.get(name) is not type(x):
            raise DocumentError(where, f"a {name} is not a part of a result")
        return {"$type": name, "fields": {
            f.name: _encode(getattr(x, f.name), f"{where}.{f.name}", types)
            for f in dataclasses.fields(x) if f.init}}
    if isinstance(x, tuple):
        return {"$tuple": [_encode(v, f"{where}[{i}]", types) for i, v in enumerate(x)]}
    if isinstance(x, list | PIStageOutputs):
        return [_encode(v, f"{where}[{i}]", types) for i, v in enumerate(x)]
    if isinstance(x, Mapping):
        out = {}
        for k, v in x.items():
            if not isinstance(k, str) or k.startswith("$"):
                raise DocumentError(where, f"the key {k!r} cannot be written")
            out[k] = _encode(v, f"{where}.{k}", types)
        return out
    raise DocumentError(where, f"a {type(x).__name__} cannot be written")


def _array_doc(a: np.ndarray, where: str) -> dict[str, Any]:
    if a.dtype.kind == "U":
        return {"dtype": "str", "shape": list(a.shape), "items": [str(v) for v in a.ravel()]}
    b = np.ascontiguousarray(a, dtype=a.dtype.newbyteorder("<"))
    if b.dtype.str not in _DTYPES:
        raise DocumentError(where, f"an array of {a.dtype} cannot be written")
    return {"dtype": b.dtype.str, "shape": list(a.shape),
            "base64": base64.b64encode(b.tobytes()).decode("ascii")}


# ------------------------------------------------------------------------------ reading
def read_document(doc: Any, fmt: str, version: int, types: Sequence[type], expect: type
                  ) -> Any:
    """The ``expect`` object of a document :func:`write_document` wrote with ``fmt``, a
    version up to ``version`` and the dataclasses ``types`` (equal to the object written:
    same fields, arrays bit for bit).

    Raises
    ------
    DocumentError
        ``doc`` is not such a document, of a later version, or damaged (says where and what).
    """
    if not isinstance(doc, dict):
        raise DocumentError("the top", f"it is a {type(doc).__name__}, not an object")
    if doc.get("format") != fmt:
        raise DocumentError("format", f"expected {fmt!r}, got {doc.get('format')!r}")
    written = doc.get("version")
    if not isinstance(written, int) or isinstance(written, bool) or written < 1:
        raise DocumentError("version", f"expected a version number, got {written!r}")
    if written > version:
        raise DocumentError("version", f"version {written} was written by a newer "
                            f"Hysteresis Explorer (this one reads {version})")
    if set(doc) != {"format", "version", "result"}:
        raise DocumentError("the top", "unexpected keys "
                            f"{sorted(set(doc) - {'format', 'version', 'result'})}")
    result = _decode(doc["result"], "result", _Types(types))
    if not isinstance(result, expect):
        raise DocumentError("result", f"a {type(result).__name__}, not a result")
    return result


def _decode(x: Any, where: str, types: _Types) -> Any:
    if x is None or isinstance(x, bool | str | int | float):
        return x
    if isinstance(x, list):
        return [_decode(v, f"{where}[{i}]", types) for i, v in enumerate(x)]
    if not isinstance(x, dict):
        raise DocumentError(where, f"a {type(x).__name__} is no JSON value")
    tags = [k for k in x if k.startswith("$")]
    if not tags:
        return {k: _decode(v, f"{where}.{k}", types) for k, v in x.items()}
    tag = tags[0]
    if tag == "$type":
        return _instance(x, where, types)
    if len(x) != 1:
        raise DocumentError(where, f"{tag} with other keys {sorted(x)}")
    v = x[tag]
    if tag == "$float":
        if v not in ("nan", "inf", "-inf"):
            raise DocumentError(where, f"$float {v!r} is not nan, inf or -inf")
        return float(v)
    if tag == "$tuple":
        if not isinstance(v, list):
            raise DocumentError(where, "$tuple does not hold a list")
        return tuple(_decode(e, f"{where}[{i}]", types) for i, e in enumerate(v))
    if tag == "$array":
        return _array(v, where)
    if tag == "$model":
        from ..base import model_from_dict

        try:
            return model_from_dict(v)
        except (ValueError, TypeError, KeyError, AttributeError) as exc:
            raise DocumentError(where, f"the model does not build ({exc})") from None
    raise DocumentError(where, f"unknown tag {tag}")


def _array(d: Any, where: str) -> np.ndarray:
    if not isinstance(d, dict):
        raise DocumentError(where, "$array does not hold an object")
    shape = d.get("shape")
    if not (isinstance(shape, list) and all(isinstance(n, int) and not isinstance(n, bool)
                                            and n >= 0 for n in shape)):
        raise DocumentError(where, f"the array's shape {shape!r} is not a list of "
                                     "sizes")
    size = math.prod(shape)
    dtype = d.get("dtype")
    if dtype == "str":
        items = d.get("items")
        if set(d) != {"dtype", "shape", "items"} or not isinstance(items, list) \
                or len(items) != size or not all(isinstance(s, str) for s in items):
            raise DocumentError(where, f"the text array does not hold {size} strings")
        return np.asarray(items, dtype=str).reshape(shape)
    if dtype not in _DTYPES or set(d) != {"dtype", "shape", "base64"} \
            or not isinstance(d["base64"], str):
        raise DocumentError(where, f"an array of type {dtype!r} is not readable")
    try:
        raw = base64.b64decode(d["base64"], validate=True)
    except (binascii.Error, ValueError):
        raise DocumentError(where, "the array's data is not base64") from None
    dt = np.dtype(dtype)
    if len(raw) != size * dt.itemsize:
        raise DocumentError(where, f"the array's data holds {len(raw)} bytes, its "
                                     f"shape {tuple(shape)} needs {size * dt.itemsize}")
    return np.frombuffer(raw, dtype=dt).astype(dt.newbyteorder("="), copy=True).reshape(shape)


def _instance(x: dict[str, Any], where: str, types: _Types) -> Any:
    name = x.get("$type")
    cls = types.by_name.get(name) if isinstance(name, str) else None
    if cls is None:
        raise DocumentError(where, f"unknown type {name!r}")
    fields_doc = x.get("fields")
    if set(x) != {"$type", "fields"} or not isinstance(fields_doc, dict):
        raise DocumentError(where, f"a {name} without its fields")
    declared = {f.name: f for f in dataclasses.fields(cls) if f.init}
    unknown = sorted(set(fields_doc) - set(declared))
    if unknown:
        raise DocumentError(where, f"a {name} has no field {unknown[0]!r}")
    missing = [n for n, f in declared.items() if n not in fields_doc
               and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if missing:
        raise DocumentError(where, f"the {name} lacks its field {missing[0]!r}")
    hints = _hints(cls)
    values = {}
    for n, v in fields_doc.items():
        value = _decode(v, f"{where}.{n}", types)
        hint = hints.get(n, Any)
        if not _fits(value, hint):
            raise DocumentError(f"{where}.{n}", f"a {type(value).__name__} is not "
                                         f"a {_hint_words(hint)}")
        values[n] = value
    try:
        return cls(**values)
    except (ValueError, TypeError, KeyError, IndexError) as exc:
        raise DocumentError(where, f"the {name} does not build ({exc})") from None


_HINTS: dict[type, dict[str, Any]] = {}


def _hints(cls: type) -> dict[str, Any]:
    """The field annotations of ``cls`` resolved (none where they do not resolve)."""
    if cls not in _HINTS:
        try:
            _HINTS[cls] = typing.get_type_hints(cls)
        except (NameError, TypeError):  # an annotation only a type checker can resolve
            _HINTS[cls] = {}
    return _HINTS[cls]


def _fits(v: Any, hint: Any) -> bool:
    """``v`` (a decoded value) is of the annotated type ``hint`` (checked one level deep
    into tuples, lists and mappings; what cannot be checked passes)."""
    if hint is Any or isinstance(hint, typing.TypeVar):
        return True
    if hint is NoneType or hint is None:
        return v is None
    origin = typing.get_origin(hint)
    args = typing.get_args(hint)
    if origin is typing.Union or origin is UnionType:
        return any(_fits(v, a) for a in args)
    if hint is float:
        return isinstance(v, int | float) and not isinstance(v, bool)
    if hint is int:
        return isinstance(v, int) and not isinstance(v, bool)
    if hint in (str, bool):
        return isinstance(v, hint)
    if origin is None:
        return not isinstance(hint, type) or isinstance(v, hint)
    if origin is np.ndarray:
        return isinstance(v, np.ndarray)
    if origin is tuple:
        if not isinstance(v, tuple):
            return False
        if len(args) == 2 and args[1] is Ellipsis:
            return all(_fits(e, args[0]) for e in v)
        return not args or (len(args) == len(v) and all(_fits(e, a) for e, a in zip(
            v, args, strict=True)))
    if origin is list:
        return isinstance(v, list) and (not args or all(_fits(e, args[0]) for e in v))
    if origin in (dict, Mapping):
        return isinstance(v, Mapping) and (not args or all(isinstance(k, str) for k in v))
    if origin is Sequence:
        return isinstance(v, list | tuple) and (not args or all(_fits(e, args[0]) for e in v))
    return True


def _hint_words(hint: Any) -> str:
    return getattr(hint, "__name__", None) or str(hint).replace("typing.", "")
