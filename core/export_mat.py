"""MATLAB ``.mat`` export of parameter sets (``scipy.io.savemat``, MAT v5).

The file holds one struct per variable:

``model``
    The model's fields, one struct field per JSON key: numbers become doubles, number arrays
    become row vectors, strings become char arrays, ``null`` becomes ``[]``. A chain's
    ``stages`` is a cell array of stage structs (``model.stages{k}.thresholds``).
``inverse``
    The inverse model in the same layout, when the model is invertible (else ``[]``).
``units``
    ``units.input``, ``units.output``, ``units.time``.
``format``, ``version``
    The parameter-set format tag and version.
``parameter_set_json``
    The whole parameter-set document as a JSON string: ``jsondecode`` in MATLAB, or
    :func:`read_mat` here, gives a lossless round trip.

JSON keys that are not valid MATLAB identifiers (``a-b``) have every invalid character
replaced with ``_``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .base import Model
from .exceptions import NotInvertibleError, ParameterError

if TYPE_CHECKING:
    from .paramset import ParameterSet

__all__ = ["export_mat", "mat_struct", "read_mat"]


def _field_name(key: str) -> str:
    s = re.sub(r"[^A-Za-z0-9_]", "_", key)
    if not s or not s[0].isalpha():
        s = "f_" + s
    return s[:63]


def mat_struct(value: Any) -> Any:
    """Convert a JSON-ready value into what ``savemat`` writes as a MATLAB value.

    Mappings become structs (dicts), lists of numbers become 1-by-n double rows, lists of
    anything else become cell arrays (object arrays), ``None`` becomes an empty double.

    Parameters
    ----------
    value : object
        Parsed-JSON value.

    Returns
    -------
    object
        Value accepted by :func:`scipy.io.savemat`.
    """
    if value is None:
        return np.zeros((0, 0))
    if isinstance(value, bool):
        return np.array([[1.0 if value else 0.0]])
    if isinstance(value, int | float):
        return float(value)
    if isinstance(value, str):
        return value
    if isinstance(value, Mapping):
        return {_field_name(str(k)): mat_struct(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        if value and all(isinstance(x, int | float) and not isinstance(x, bool) for x in value):
            return np.asarray(value, dtype=np.float64).reshape(1, -1)
        if value and all(isinstance(x, list | tuple) for x in value):
            try:  # a matrix (e.g. state-space A) when rows are equal-length numbers
                arr = np.asarray(value, dtype=np.float64)
                if arr.ndim == 2:
                    return arr
            except (TypeError, ValueError):
                pass
        cell = np.empty((1, len(value)), dtype=object)
        for i, x in enumerate(value):
            cell[0, i] = mat_struct(x)
        return cell
    raise ParameterError(f"cannot store a {type(value).__name__} in a .mat file")


def export_mat(
    pset: ParameterSet | Model, path: str | Path, *, include_inverse: bool = True
) -> Path:
    """Write a parameter set (or a bare model) to a MATLAB ``.mat`` file.

    Parameters
    ----------
    pset : ParameterSet or Model
        A bare model is wrapped with default units and fresh provenance.
    path : str or Path
        Output file; ``.mat`` is appended if missing. Parent directories are created.
    include_inverse : bool
        Also store the inverse model (as ``inverse``) when it exists.

    Returns
    -------
    Path
        The file written.
    """
    from scipy.io import savemat

    from .paramset import FORMAT, VERSION, ParameterSet

    if isinstance(pset, Model):
        pset = ParameterSet.from_model(pset)
    doc = pset.to_dict()
    inverse: Any = np.zeros((0, 0))
    if include_inverse:
        try:
            inverse = mat_struct(pset.model.inverse().to_dict())
        except NotInvertibleError:
            pass
    p = Path(path)
    if p.suffix != ".mat":
        p = p.with_name(p.name + ".mat")
    p.parent.mkdir(parents=True, exist_ok=True)
    data = {
        "format": FORMAT,
        "version": float(VERSION),
        "model": mat_struct(doc["model"]),
        "inverse": inverse,
        "units": mat_struct(doc["units"]),
        "provenance": mat_struct(doc["provenance"]),
        "parameter_set_json": pset.to_json(indent=None),
    }
    savemat(p, data, do_compression=True, oned_as="row")
    return p


def read_mat(path: str | Path) -> ParameterSet:
    """Read back a file written by :func:`export_mat` (from its ``parameter_set_json``).

    Raises
    ------
    ParameterError
        If the file has no ``parameter_set_json`` variable.
    """
    from scipy.io import loadmat

    from .paramset import load_parameter_set

    d = loadmat(Path(path), squeeze_me=True)
    if "parameter_set_json" not in d:
        raise ParameterError(
            f"{path}: no parameter_set_json variable; this .mat file was not written by "
            "hyst export --format mat"
        )
    return load_parameter_set(str(d["parameter_set_json"]))
