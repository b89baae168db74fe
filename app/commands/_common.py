"""Helpers shared by the ``hyst`` sub-commands: model files, CSV signals, JSON output, windows.

Errors raised here are :class:`CommandError` (a :class:`~core.exceptions.ParameterError`),
which :func:`app.cli.main` turns into ``hyst <command>: error: <message>`` and exit code 2.
"""

from __future__ import annotations

import argparse
import csv
import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from app.services.runs.inputs import CommandError, existing_file, parse_window

if TYPE_CHECKING:
    from core.paramset import ParameterSet

__all__ = [
    "add_json_flag",
    "add_threads_option",
    "emit",
    "pick_column",
    "read_parameter_set",
    "uniform_dt",
    "window_arg",
    "write_columns",
]


def add_json_flag(parser: argparse.ArgumentParser) -> None:
    """Add ``--json``: print a machine-readable summary on stdout instead of text."""
    parser.add_argument(
        "--json",
        action="store_true",
        help="print a machine-readable JSON summary on stdout (messages go to stderr)",
    )


def add_threads_option(parser: argparse.ArgumentParser) -> None:
    """Add ``--threads N``: BLAS / OpenMP / numba threads of the command (default 1;
    :mod:`core.threads` says why). :func:`app.cli.main` applies it around the command."""
    from core.threads import DEFAULT_THREADS, max_threads

    parser.add_argument(
        "--threads", type=_threads, default=DEFAULT_THREADS, metavar="N",
        help=f"threads of the numeric libraries (default {DEFAULT_THREADS}: fastest when "
             f"other work shares the machine; up to {max_threads()} here)")


def _threads(text: str) -> int:
    from core.threads import check_threads

    try:
        return check_threads(int(text))
    except ValueError as exc:  # int() of a non-number, or out of range
        msg = str(exc) if text.strip().lstrip("+-").isdigit() else \
            f"--threads takes a whole number of threads, got {text!r}"
        raise argparse.ArgumentTypeError(msg.replace("threads must", "--threads must")) from None


def emit(args: argparse.Namespace, text: str, data: dict[str, Any]) -> None:
    """Print ``data`` as JSON when ``--json`` was given, else ``text``, on stdout."""
    if getattr(args, "json", False):
        print(json.dumps(data, indent=2, allow_nan=False, default=_json_default))
    else:
        print(text)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def read_parameter_set(path: str | Path, *, require_inverse: bool = False) -> ParameterSet:
    """Read a model file: a parameter-set document, or a bare ``Model.to_dict()`` object.

    Parameters
    ----------
    path : str or Path
        JSON file.
    require_inverse : bool
        Fail with ``NotInvertibleError`` when the model has no inverse.

    Returns
    -------
    ParameterSet
        A bare model is wrapped with default units and ``source`` = the file name.

    Raises
    ------
    CommandError
        Missing file.
    ParameterSetError
        Malformed document (the message names the file and the JSON path).
    """
    from app.services.session.exports import parameter_set_from_document
    from core.paramset import ParameterSetError

    p = existing_file(path, "model file")
    text = p.read_text(encoding="utf-8")
    try:
        doc = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise ParameterSetError(
            f"{p}: not valid JSON: {exc.msg} at line {exc.lineno} column {exc.colno}"
        ) from exc
    except ValueError as exc:
        raise ParameterSetError(f"{p}: {exc}") from exc
    try:
        return parameter_set_from_document(doc, source=p.name, require_inverse=require_inverse)
    except ParameterSetError as exc:
        raise ParameterSetError(f"{p}: {exc}") from exc


def _reject_constant(name: str) -> Any:
    raise ValueError(f"JSON contains {name}; every parameter must be a finite number")


# ----------------------------------------------------------------------------- CSV signals
def pick_column(
    names: Sequence[str], wanted: str | None, defaults: Sequence[str], fallback: int | None,
    what: str, path: str | Path,
) -> int:
    """Index of a column chosen by name (or 0-based number), by default names, or by position.

    Raises
    ------
    CommandError
        Naming the available columns.
    """
    if wanted is not None:
        if wanted in names:
            return list(names).index(wanted)
        if wanted.isdigit() and int(wanted) < len(names):
            return int(wanted)
        raise CommandError(
            f"{path}: no {what} column {wanted!r}; columns are: {', '.join(names)}"
        )
    for d in defaults:
        if d in names:
            return list(names).index(d)
    if fallback is not None and fallback < len(names):
        return fallback
    raise CommandError(
        f"{path}: cannot tell which column is the {what}; columns are: {', '.join(names)} "
        f"(name it with --{what})"
    )


def write_columns(path: str | Path, names: Sequence[str], columns: Sequence[np.ndarray]) -> Path:
    """Write columns as CSV with a header row.

    Parameters
    ----------
    path : str or Path
        Destination file (overwritten); parent directories are created.
    names : sequence of str
        Column headers (quoted only when they hold a comma or a quote).
    columns : sequence of ndarray of shape (N,)
        Numeric columns are written as the shortest exact (round-trip) float text; text
        columns (e.g. date-times copied from an input file) verbatim.

    Returns
    -------
    Path
        The path written.
    """
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    arrays = [np.asarray(c) for c in columns]
    with p.open("w", encoding="utf-8", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(names)
        if all(a.dtype.kind in "biuf" for a in arrays):
            data = np.column_stack([a.astype(np.float64) for a in arrays])
            for row in data.tolist():
                fh.write(",".join(repr(v) for v in row) + "\n")
        else:
            cells = [
                [repr(v) for v in a.astype(np.float64).tolist()] if a.dtype.kind in "biuf"
                else [str(v) for v in a.tolist()]
                for a in arrays
            ]
            writer.writerows(zip(*cells, strict=True))
    return p


def uniform_dt(t: np.ndarray, path: str | Path, rel_tol: float = 1e-3) -> float:
    """The sample spacing of a uniformly sampled time column.

    Raises
    ------
    CommandError
        If ``t`` does not increase uniformly (within ``rel_tol``).
    """
    if t.size < 2:
        raise CommandError(f"{path}: need at least two time samples to know dt; give --dt")
    d = np.diff(t)
    dt = float(np.median(d))
    if not dt > 0 or np.max(np.abs(d - dt)) > rel_tol * dt:
        raise CommandError(
            f"{path}: the time column is not uniformly sampled (spacing between "
            f"{d.min():g} and {d.max():g}); dynamic models need a constant dt: resample, or "
            "give --dt"
        )
    return dt


def window_arg(what: str) -> Any:
    """An argparse ``type=`` for ``--<what> T0:T1`` that reports errors as usage errors."""

    def convert(text: str) -> tuple[float, float]:
        try:
            return parse_window(text, what)
        except CommandError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    return convert
