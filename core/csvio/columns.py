"""Columns to roles (time, input, output, run) and cells to numbers."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from datetime import datetime
from typing import Literal, overload

import numpy as np

from .errors import CSVError
from .names import (
    INDEX_NAMES,
    INPUT_NAMES,
    OUTPUT_NAMES,
    RUN_NAMES,
    TIME_NAMES,
    ColumnInfo,
    parse_column_name,
)
from .numbers import DECIMAL_COMMA, NA_TOKENS
from .options import ColumnSpec
from .table import Table

__all__ = ["available", "choose_roles", "convert", "convert_time"]


def available(cols: Sequence[ColumnInfo]) -> str:
    return ", ".join(f"{c.index}: {c.raw!r}" for c in cols)


def find_column(spec: int | str, role: str, cols: Sequence[ColumnInfo], label: str) -> ColumnInfo:
    if isinstance(spec, bool):
        raise CSVError(f"{role}={spec!r}: give a column name or 0-based index", source=label)
    if isinstance(spec, (int, np.integer)):
        j = int(spec)
        if not 0 <= j < len(cols):
            raise CSVError(
                f"{label}: {role}={j} is not a column index; the file has {len(cols)} "
                f"columns (0..{len(cols) - 1}): {available(cols)}", source=label,
            )
        return cols[j]
    if not isinstance(spec, str):
        raise CSVError(f"{role}={spec!r} must be a column name or a 0-based index",
                       source=label)
    want = spec.strip().lower()
    hits = [c for c in cols if c.raw.strip().lower() == want]
    if not hits:
        key = parse_column_name(spec)[0].lower()
        hits = [c for c in cols if c.key == key]
    if not hits:
        raise CSVError(
            f"{label}: no column named {spec!r} for {role}; available columns: "
            f"{available(cols)} (names match without case and unit, or give the index)",
            source=label, column=spec,
        )
    if len(hits) > 1:
        raise CSVError(
            f"{label}: {role}={spec!r} matches several columns ({available(hits)}); "
            "pick one by its 0-based index", source=label, column=spec,
        )
    return hits[0]


def by_name(cols: Iterable[ColumnInfo], names: frozenset[str],
             prefixes: tuple[str, ...] = ()) -> ColumnInfo | None:
    for c in cols:
        if c.key in names or any(c.key.startswith(p) for p in prefixes):
            return c
    return None



@overload
def convert(table: Table, col: ColumnInfo, *, strict: Literal[True], role: str) -> np.ndarray:
    ...


@overload
def convert(table: Table, col: ColumnInfo, *, strict: bool, role: str) -> np.ndarray | None:
    ...


def convert(
    table: Table, col: ColumnInfo, *, strict: bool, role: str
) -> np.ndarray | None:
    """Column as float64 (NA tokens → NaN). Non-numeric: error if strict, else None."""
    dec = table.layout.decimal
    m = table.matrix()
    if m is not None:
        return np.array(m[:, col.index])
    cells = table.column(col.index)
    if dec == ",":
        # a "." in a decimal-comma file is an error, not a second decimal mark
        cells = [c.replace(",", ".") if "." not in c else "?" for c in cells]
    try:
        arr = np.asarray(cells, dtype=np.float64)
        if not any("_" in c for c in cells):
            return arr
    except ValueError:
        pass
    out = np.empty(len(cells))
    for i, c in enumerate(cells):
        s = c.strip()
        if s.lower() in NA_TOKENS:
            out[i] = np.nan
            continue
        try:
            if "_" in s or s == "?":
                raise ValueError(s)
            out[i] = float(s)
        except ValueError:
            if not strict:
                return None
            line = int(table.lines[i])
            original = table.rows[i][col.index]
            hint = "fix or delete that row"
            if dec == "," and "." in original:
                hint = "the file uses decimal commas elsewhere; write it with a comma"
            elif dec == "." and DECIMAL_COMMA.match(original.strip()):
                hint = "it looks like a decimal comma: pass decimal=','"
            elif i == 0 and not table.layout.header:
                hint = "if that line holds column names, pass header=True"
            raise CSVError(
                f"{table.layout.source}: line {line}, {role} column {col.label()}: "
                f"{original!r} is not a number; {hint}",
                source=table.layout.source, line=line, column=col.raw, column_index=col.index,
            ) from None
    return out


def convert_time(table: Table, col: ColumnInfo) -> tuple[np.ndarray, str | None]:
    """Time column as float64; ISO date-times become seconds since the first stamp."""
    arr = convert(table, col, strict=False, role="time")
    if arr is not None:
        return arr, None
    stamps: list[datetime | None] = []
    for c in table.column(col.index):
        c = c.strip()
        if c.lower() in NA_TOKENS:
            stamps.append(None)
            continue
        try:
            stamps.append(datetime.fromisoformat(c.replace(",", ".")))
        except ValueError:
            # not date-times either: report the first non-number
            return convert(table, col, strict=True, role="time"), None
    valid = [s for s in stamps if s is not None]
    if not valid:
        return convert(table, col, strict=True, role="time"), None
    t0 = valid[0]
    try:
        out = np.array([np.nan if s is None else (s - t0).total_seconds() for s in stamps])
    except TypeError as exc:  # naive and aware stamps mixed
        raise CSVError(
            f"{table.layout.source}: time column {col.label()} mixes date-times with and "
            f"without a time zone ({exc}); write them all the same way",
            source=table.layout.source, column=col.raw, column_index=col.index,
        ) from None
    return out, f"time column {col.raw!r} holds date-times; converted to seconds since {t0}"


def choose_roles(  # noqa: C901 - one rule per column role, read in order
    table: Table, *, time: ColumnSpec, input: ColumnSpec,  # noqa: A002 - role name
    output: ColumnSpec, run: ColumnSpec, with_output: bool,
) -> tuple[dict[str, ColumnInfo | None], list[str], bool]:
    """Pick the run, time, input (and output) columns; see the module docstring.

    Returns
    -------
    chosen : dict
        ``"run"``, ``"time"``, ``"input"`` (and ``"output"`` when ``with_output``) to the
        column, or None for run / time when there is none.
    notes : list of str
        How a missing time axis was interpreted.
    time_auto : bool
        Whether the time column was taken by position (it must then increase, else the
        error asks for ``time=``).
    """
    lay = table.layout
    label = lay.source
    cols = list(lay.columns)
    chosen: dict[str, ColumnInfo | None] = {}
    specs: list[tuple[str, ColumnSpec]] = [("run", run), ("time", time), ("input", input)]
    if with_output:
        specs.append(("output", output))
    for role, spec in specs:
        if spec is None or spec is False:
            chosen[role] = None
        else:
            chosen[role] = find_column(spec, role, cols, label)
    taken: dict[int, str] = {}
    for role, c in chosen.items():
        if c is not None:
            taken.setdefault(c.index, role)
    for role, c in chosen.items():
        if c is not None and taken[c.index] != role:
            raise CSVError(
                f"{label}: {taken[c.index]} and {role} both refer to column {c.label()}; "
                "pick a different column for one of them", source=label, column=c.raw,
                column_index=c.index,
            )

    def free() -> list[ColumnInfo]:
        used = {c.index for c in chosen.values() if c is not None}
        return [c for c in cols if c.index not in used]

    if run is None and lay.header:
        chosen["run"] = by_name(free(), RUN_NAMES)
    index_col = by_name(free(), INDEX_NAMES) if lay.header else None
    if index_col is not None:
        # a sample index holds whole numbers that increase (within each run) and has no unit
        k = convert(table, index_col, strict=False, role="index")
        if index_col.unit or k is None or not np.all(np.isfinite(k)) or np.any(k != np.round(k)):
            index_col = None
    notes_roles: list[str] = []
    time_auto = False
    want_output = with_output and output is None
    if time is None:
        named = by_name(free(), TIME_NAMES) if lay.header else None
        if named is not None:
            chosen["time"] = named
        elif index_col is not None:
            notes_roles.append(f"no time column: column {index_col.label()} is a sample index")
        else:
            cand = free()
            needed = 1 + (input is None) + want_output
            least = 2 + with_output - (input is not None) - (with_output and output is not None)
            io_named = lay.header and cand and by_name(
                cand[:1], INPUT_NAMES | OUTPUT_NAMES, ("u_", "y_", "input_", "output_")
            )
            if not io_named and len(cand) >= max(needed, least):
                chosen["time"] = cand[0]
                time_auto = True
            else:
                notes_roles.append("no time column: the time axis is the sample index")
    roles = [("input", INPUT_NAMES, ("u_", "input_"))]
    if with_output:
        roles.append(("output", OUTPUT_NAMES, ("y_", "output_")))
    for role, names, prefixes in roles:
        if chosen[role] is None:
            pool = [c for c in free() if c is not index_col]
            hit = by_name(pool, names, prefixes) if lay.header else None
            if hit is None:
                # never take a column that another role's name claims
                other = OUTPUT_NAMES if role == "input" else INPUT_NAMES
                opre = ("y_", "output_") if role == "input" else ("u_", "input_")
                pool2 = [c for c in pool if not (lay.header and by_name([c], other, opre))]
                hit = pool2[0] if pool2 else (pool[0] if pool else None)
            if hit is None:
                need = ("a recording needs an input and an output column" if with_output
                        else "pick the input column with input=")
                raise CSVError(
                    f"{label}: no column left for the {role}; the file has {len(cols)} "
                    f"column(s): {available(cols)}; {need}", source=label,
                )
            chosen[role] = hit
    return chosen, notes_roles, time_auto

