"""``hyst fit FILE.csv ... --output MODEL.json``: identify a model from recordings."""

from __future__ import annotations

import argparse
import inspect
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ._common import (
    CommandError,
    Progress,
    add_json_flag,
    emit,
    pick_column,
    read_columns,
    unit_from_column,
)

__all__ = ["MODELS", "parse_window", "register", "run"]

#: ``--model`` choice -> estimator class name in :mod:`core.fitting`.
MODELS = {
    "pi": "PIRegressor",
    "gpi-deadzone": "DeadZoneGPIRegressor",
    "mpi": "ModifiedPIRegressor",
    "gpi-tanh": "TanhGPIRegressor",
    "digitized": "DigitizedPIRegressor",
}


def register(subparsers: Any) -> None:
    """Add the ``fit`` sub-command."""
    p = subparsers.add_parser(
        "fit",
        help="fit an invertible PI-family model to measured input/output recordings",
        description=(
            "Read one or more CSV recordings (header row; time, input and output columns: by "
            "default 't'/'u'/'y' or the first three columns), fit the chosen model and save "
            "it as a parameter set with the fit report (train / held-out RMSE, inverse "
            "check) in its provenance. Without --train/--test the last 20 %% of every "
            "recording is held out. Progress goes to stderr."
        ),
    )
    p.add_argument("files", nargs="+", metavar="FILE.csv", help="recording(s)")
    p.add_argument("--model", default="pi", choices=tuple(MODELS), help="model family")
    p.add_argument("-n", "--n-operators", type=int, metavar="N",
                   help="number of play operators (default: chosen by cross-validation)")
    p.add_argument("--time", metavar="COL", help="time column (default: t or column 0)")
    p.add_argument("--input-column", metavar="COL",
                   help="input column (default: u or column 1)")
    p.add_argument("--output-column", metavar="COL",
                   help="output column (default: y or column 2)")
    p.add_argument("--train", metavar="T0:T1",
                   help="fit only samples with T0 <= t < T1 (either side may be empty)")
    p.add_argument("--test", metavar="T0:T1",
                   help="held-out samples for the report, T0 <= t < T1")
    p.add_argument("-o", "--output", required=True, metavar="MODEL.json",
                   help="where to write the fitted parameter set")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    add_json_flag(p)
    p.set_defaults(func=run)


def parse_window(text: str, what: str) -> tuple[float, float]:
    """Parse ``"T0:T1"`` (either side may be empty) into ``(t0, t1)``.

    Raises
    ------
    CommandError
        Naming the option and the expected form.
    """
    parts = text.split(":")
    if len(parts) != 2:
        raise CommandError(f"--{what} {text!r}: expected T0:T1 in seconds, e.g. 0:8 or 8:")
    try:
        t0 = float(parts[0]) if parts[0].strip() else -np.inf
        t1 = float(parts[1]) if parts[1].strip() else np.inf
    except ValueError:
        raise CommandError(f"--{what} {text!r}: T0 and T1 must be numbers, e.g. 0:8") from None
    if not t0 < t1:
        raise CommandError(f"--{what} {text!r}: T0 must be smaller than T1")
    return t0, t1


def _estimator(name: str, n: int | None) -> Any:
    import importlib

    fitting = importlib.import_module("core.fitting")
    cls = getattr(fitting, MODELS[name], None)
    if cls is None:
        raise CommandError(
            f"--model {name}: this installation has no core.fitting.{MODELS[name]} yet; "
            "use --model pi"
        )
    kwargs: dict[str, Any] = {}
    if n is not None:
        params = inspect.signature(cls).parameters
        key = next((k for k in ("n_operators", "n", "n_digits") if k in params), None)
        if key is None:
            raise CommandError(f"--model {name} does not take a number of operators (-n)")
        kwargs[key] = n
    return cls(**kwargs)


def run(args: argparse.Namespace) -> int:
    """Fit and save."""
    from core.paramset import ParameterSet

    progress = Progress("fit", quiet=args.quiet or args.json)
    train_w = parse_window(args.train, "train") if args.train else None
    test_w = parse_window(args.test, "test") if args.test else None
    if args.n_operators is not None and args.n_operators < 1:
        raise CommandError(f"-n must be a positive number of operators, got {args.n_operators}")
    us, ys, trains, tests = [], [], [], []
    cols: tuple[str, str, str] | None = None
    for f in args.files:
        names, data = read_columns(f)
        it = pick_column(names, args.time, ("t", "time", "t_s"), 0, "time", f)
        iu = pick_column(names, args.input_column, ("u",), 1, "input-column", f)
        iy = pick_column(names, args.output_column, ("y",), 2, "output-column", f)
        if len({it, iu, iy}) < 3:
            raise CommandError(
                f"{f}: time, input and output must be three different columns, got "
                f"{names[it]!r}, {names[iu]!r}, {names[iy]!r}"
            )
        cols = cols or (names[it], names[iu], names[iy])
        t = data[:, it]
        us.append(data[:, iu])
        ys.append(data[:, iy])
        if train_w is not None:
            trains.append((t >= train_w[0]) & (t < train_w[1]))
        if test_w is not None:
            tests.append((t >= test_w[0]) & (t < test_w[1]))
        progress(f"read {f}: {t.size} samples, t = {t[0]:g} .. {t[-1]:g}, "
                 f"u = {names[iu]}, y = {names[iy]}")
    for lab, masks in (("--train", trains), ("--test", tests)):
        if masks and not any(m.any() for m in masks):
            raise CommandError(f"{lab} window selects no samples; check it against the t column")
    multi = len(us) > 1
    est = _estimator(args.model, args.n_operators)
    progress(f"fitting {args.model}" + (f" with n = {args.n_operators}" if args.n_operators
                                         else " (choosing n by cross-validation)"))
    kw: dict[str, Any] = {}
    if trains:
        kw["train"] = trains if multi else trains[0]
    if tests:
        kw["test"] = tests if multi else tests[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        est.fit(us if multi else us[0], ys if multi else ys[0], **kw)
    msgs = [str(w.message) for w in caught]
    for m in msgs:
        progress(f"warning: {m}")
    model = getattr(est, "full_model_", None) or est.model_
    report = est.report_.to_dict() if hasattr(est, "report_") else None
    assert cols is not None
    units = {
        "input": unit_from_column(cols[1]) or "V",
        "output": unit_from_column(cols[2]) or "um",
        "time": unit_from_column(cols[0]) or "s",
    }
    fit_info = {
        "model": args.model,
        "files": [Path(f).name for f in args.files],
        "columns": {"time": cols[0], "input": cols[1], "output": cols[2]},
        "train": args.train,
        "test": args.test,
        "n_operators": args.n_operators,
        "report": report,
        "warnings": msgs,
    }
    ps = ParameterSet.from_model(
        model, units=units, source="hyst fit " + " ".join(Path(f).name for f in args.files),
        fit=fit_info,
    )
    path = ps.save(args.output)
    progress(f"wrote {path}")
    summary = est.report_.summary() if hasattr(est.report_, "summary") else ""
    emit(args, f"{summary}\nwrote {path}",
         {"output": str(path), "model": ps.model.to_dict(), "units": units, "report": report,
          "warnings": msgs})
    return 0
