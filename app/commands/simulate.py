"""``hyst simulate MODEL.json --input IN.csv --output OUT.csv``: run a model on a signal."""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from app.services.runs.inputs import CommandError, existing_file

from ._common import (
    add_json_flag,
    add_threads_option,
    emit,
    pick_column,
    read_parameter_set,
    uniform_dt,
    write_columns,
)

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``simulate`` sub-command."""
    p = subparsers.add_parser(
        "simulate",
        help="apply a model to an input signal from a CSV file",
        description=(
            "Read IN.csv (header row; a time column and an input column, by default 't' and "
            "'u' or the first two columns; other columns, e.g. a measured 'y', are copied "
            "through; delimiter, decimal comma, comment lines and units are handled as by "
            "hyst fit), apply the model from its initial state and write OUT.csv with the "
            "input columns plus the output column. Dynamic models take dt from the "
            "(uniform) time column, in s or with its unit (t_ms, t [us]), or from --dt."
        ),
    )
    p.add_argument("model", metavar="MODEL.json", help="parameter set (or bare model)")
    p.add_argument("-i", "--input", required=True, metavar="IN.csv", help="input signal")
    p.add_argument("-o", "--output", required=True, metavar="OUT.csv", help="result file")
    p.add_argument("--time", metavar="COL", help="time column name (default: t, or column 0)")
    p.add_argument("--input-column", metavar="COL",
                   help="input column name (default: u, or column 1)")
    p.add_argument("--output-name", default="y", metavar="NAME",
                   help="name of the output column written (default: y)")
    p.add_argument("--dt", type=float, help="sample time in s (overrides the time column)")
    p.add_argument("--inverse", action="store_true",
                   help="apply the model's inverse (the compensator) instead of the model")
    add_json_flag(p)
    add_threads_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Simulate and write the output CSV.

    The input file is read by :func:`core.csvio.read_input` (its ``CSVError`` names the
    line, the column and the fix); every column is written back as read, followed by the
    model output, one row per input sample.
    """
    from core.csvio import inspect_csv, read_input

    ps = read_parameter_set(args.model, require_inverse=args.inverse)
    model = ps.model.inverse() if args.inverse else ps.model
    src = existing_file(args.input, "CSV file")
    layout = inspect_csv(src, min_columns=1)
    if not layout.header:
        raise CommandError(f"{src}: the first row must name the columns (e.g. t,u), got numbers")
    names = [c.raw for c in layout.columns]
    if len(names) == 1 and args.time is None:
        it, iu = None, pick_column(names, args.input_column, ("u",), 0, "input", args.input)
    else:
        it = pick_column(names, args.time, ("t", "time", "t_s"), 0, "time", args.input)
        iu = pick_column(names, args.input_column, ("u",), 1, "input", args.input)
        if it == iu:
            raise CommandError(
                f"{args.input}: the time and input columns are both {names[iu]!r}; "
                "name them with --time and --input-column"
            )
    if args.output_name in names:
        raise CommandError(
            f"{args.input} already has a column {args.output_name!r}; choose --output-name"
        )
    dt = args.dt
    if dt is not None and not (np.isfinite(dt) and dt > 0):
        raise CommandError(f"--dt must be a positive number of seconds, got {dt}")
    need_time = model.is_dynamic and dt is None
    if need_time and it is None:
        raise CommandError(f"{args.input}: the model has dynamics; give --dt or a time column")
    # the time column is only checked (increasing, unit, uniform) when dt comes from it
    sig = read_input(src, time=it if need_time else False, input=iu, header=True,
                     nan="error", uneven="keep")
    if need_time:
        dt = uniform_dt(sig.t, args.input)
    for note in sig.cleaning:
        print(f"hyst simulate: note: {note}", file=sys.stderr)
    u = sig.u
    preview = model.preview_samples(dt) if dt else 0
    if preview:
        print(f"hyst simulate: note: the inverse compensates a delay with a preview of "
              f"{preview} sample(s): it reads the known trajectory ahead (the last {preview} "
              "sample(s) hold the final value)", file=sys.stderr)
    y = model(u, dt=dt)
    path = write_columns(args.output, [*names, args.output_name], [*sig.values, y])
    text = (
        f"wrote {path}: {u.size} samples, {args.output_name} in "
        f"[{y.min():.6g}, {y.max():.6g}] {ps.units.input if args.inverse else ps.units.output}"
    )
    emit(args, text, {"output": str(path), "n_samples": int(u.size), "dt": dt,
                      "preview_samples": preview,
                      "y_min": float(y.min()), "y_max": float(y.max()),
                      "notes": list(sig.cleaning)})
    return 0
