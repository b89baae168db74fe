"""Argument checks shared by the models: each failure names the parameter and the rule."""

from __future__ import annotations

from typing import TypeVar

import numpy as np

from ._typing import ArrayLike, Float1D, Float2D
from .exceptions import ParameterError

_T = TypeVar("_T")

__all__ = [
    "as_finite_scalar",
    "as_input_signal",
    "as_matrix",
    "as_state_vector",
    "as_vector",
    "filled",
    "frozen",
]


def filled(value: _T | None) -> _T:
    """``value``, which the caller knows is set: a model field that ``__post_init__`` always
    fills (``None`` is only the constructor's default, "relaxed"), or a result part that
    the branch taken computed. ``None`` there is a bug (``TypeError``)."""
    if value is None:  # pragma: no cover - __post_init__ fills every such field
        raise TypeError("a value that is always set was None")
    return value


def frozen(a: np.ndarray) -> np.ndarray:
    """Return ``a`` (float64, C-contiguous) marked read-only."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    a.flags.writeable = False
    return a


def as_vector(
    x: ArrayLike,
    name: str,
    *,
    length: int | None = None,
    min_length: int = 1,
    nonnegative: bool = False,
    positive: bool = False,
    increasing: bool = False,
) -> Float1D:
    """Convert ``x`` to a finite read-only float64 vector and check the named rules.

    Parameters
    ----------
    x : array_like of shape (n,)
        Values to check.
    name : str
        Parameter name used in error messages.
    length : int, optional
        Required length.
    min_length : int
        Smallest allowed length (default 1: empty arrays are rejected).
    nonnegative, positive, increasing : bool
        Extra rules: ``x >= 0``, ``x > 0``, strictly increasing.

    Returns
    -------
    ndarray of shape (n,)

    Raises
    ------
    ParameterError
        Naming ``name`` and the rule that failed.
    """
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be numeric: {exc}") from exc
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise ParameterError(f"{name} must be one-dimensional, got shape {a.shape}")
    if a.size < min_length:
        raise ParameterError(
            f"{name} must have at least {min_length} element(s), got {a.size}"
        )
    if length is not None and a.size != length:
        raise ParameterError(f"{name} must have length {length} (one per operator), got {a.size}")
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ParameterError(f"{name}[{i}] = {a[i]} is not finite; every value must be a number")
    if nonnegative and (a < 0).any():
        i = int(np.flatnonzero(a < 0)[0])
        raise ParameterError(f"{name}[{i}] = {a[i]:g} is negative; {name} must be >= 0")
    if positive and (a <= 0).any():
        i = int(np.flatnonzero(a <= 0)[0])
        raise ParameterError(f"{name}[{i}] = {a[i]:g} is not positive; {name} must be > 0")
    if increasing and a.size > 1:
        d = np.diff(a)
        if (d <= 0).any():
            i = int(np.flatnonzero(d <= 0)[0])
            raise ParameterError(
                f"{name} must be strictly increasing, but {name}[{i}] = {a[i]:g} "
                f">= {name}[{i + 1}] = {a[i + 1]:g}; sort them and remove duplicates"
            )
    return frozen(a)


def as_state_vector(x: ArrayLike | None, n: int, name: str = "state0") -> Float1D:
    """An operator bank's initial state: ``None`` gives zeros, a scalar is given to every
    one of the ``n`` operators, a vector must have length ``n``.

    Parameters
    ----------
    x : None, float or array_like of shape (n,)
    n : int
        Number of operators.
    name : str
        Parameter name used in error messages.

    Returns
    -------
    ndarray of shape (n,)
        Finite and read-only.
    """
    if x is None:
        return frozen(np.zeros(n))
    s = np.asarray(x, dtype=np.float64)
    return as_vector(np.full(n, float(s)) if s.ndim == 0 else s, name, length=n)


def as_matrix(
    x: ArrayLike,
    name: str,
    *,
    shape: tuple[int, int] | None = None,
    nonnegative: bool = False,
) -> Float2D:
    """Convert ``x`` to a finite read-only float64 matrix and check the named rules.

    Parameters
    ----------
    x : array_like of shape (n, m)
        Values to check (a list of equal-length rows).
    name : str
        Parameter name used in error messages (entries are named ``name[i][j]``, the JSON
        path of the entry).
    shape : tuple of int, optional
        Required shape ``(n, m)``.
    nonnegative : bool
        Require every entry ``>= 0``.

    Returns
    -------
    ndarray of shape (n, m)

    Raises
    ------
    ParameterError
        Naming ``name`` (and the entry) and the rule that failed.
    """
    try:
        a = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(
            f"{name} must be a matrix of numbers (a list of equal-length rows): {exc}"
        ) from exc
    if a.ndim != 2:
        raise ParameterError(
            f"{name} must be two-dimensional (a list of rows), got shape {a.shape}"
        )
    if a.size == 0:
        raise ParameterError(f"{name} must not be empty, got shape {a.shape}")
    if shape is not None and a.shape != tuple(shape):
        raise ParameterError(
            f"{name} must have shape {tuple(shape)} (rows, columns), got {a.shape}"
        )
    bad = ~np.isfinite(a)
    if bad.any():
        i, j = (int(v) for v in np.argwhere(bad)[0])
        raise ParameterError(
            f"{name}[{i}][{j}] = {a[i, j]} is not finite; every value must be a number"
        )
    if nonnegative and (a < 0).any():
        i, j = (int(v) for v in np.argwhere(a < 0)[0])
        raise ParameterError(f"{name}[{i}][{j}] = {a[i, j]:g} is negative; {name} must be >= 0")
    return frozen(a)


def as_finite_scalar(x: object, name: str, *, positive: bool = False) -> float:
    """Convert ``x`` to a finite float, optionally requiring ``x > 0``."""
    try:
        v = float(x)  # type: ignore[arg-type]
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a number, got {x!r}") from exc
    if not np.isfinite(v):
        raise ParameterError(f"{name} = {v} is not finite; it must be a number")
    if positive and v <= 0:
        raise ParameterError(f"{name} = {v:g} must be > 0")
    return v


def as_input_signal(u: ArrayLike, name: str = "u") -> Float1D:
    """Convert an input signal to a finite C-contiguous float64 vector (may be empty).

    Raises
    ------
    ParameterError
        If ``u`` is not one-dimensional or holds NaN/inf (the index is named).
    """
    try:
        a = np.ascontiguousarray(u, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be a numeric array: {exc}") from exc
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise ParameterError(f"{name} must be one-dimensional (shape (N,)), got shape {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ParameterError(
            f"{name}[{i}] = {a[i]} is not finite; remove or interpolate NaN/inf samples first"
        )
    return a
