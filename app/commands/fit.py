"""``hyst fit FILE.csv ... --output MODEL.json``: identify a model from recordings."""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path
from typing import Any

from ._common import (
    CommandError,
    Progress,
    add_json_flag,
    column_spec,
    emit,
    existing_file,
    parse_window,
)

__all__ = ["add_model_option", "add_read_options", "read_kwargs", "register", "run", "say_read"]


def add_read_options(p: argparse.ArgumentParser) -> None:
    """The CSV options ``hyst fit`` and ``hyst diagnose`` share (one reader: core.csvio)."""
    p.add_argument("--time", metavar="COL",
                   help="time column, name or 0-based index (default: detected); 'none' for "
                        "files without one (the sample index is used)")
    p.add_argument("--input-column", metavar="COL",
                   help="input column, name or 0-based index (default: u/u_*/input)")
    p.add_argument("--output-column", metavar="COL",
                   help="output column, name or 0-based index (default: y/y_*/output)")
    p.add_argument("--run-column", metavar="COL",
                   help="column whose value splits the file into recordings (default: a "
                        "column named run/record/loop/trial; 'none' to disable)")
    p.add_argument("--resample", nargs="?", const="auto", metavar="DT",
                   help="interpolate uneven time stamps onto a uniform grid (at the median "
                        "spacing, or every DT seconds)")


def _spec(value: str | None) -> Any:
    if value is not None and value.strip().lower() == "none":
        return False
    return column_spec(value)


def read_kwargs(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`core.csvio.read_csv` from :func:`add_read_options`."""
    resample: bool | float = False
    if args.resample is not None:
        if args.resample == "auto":
            resample = True
        else:
            try:
                resample = float(args.resample)
            except ValueError:
                raise CommandError(f"--resample {args.resample!r}: expected a spacing in "
                                   "seconds, e.g. --resample 0.0002, or no value") from None
            if not resample > 0:
                raise CommandError(f"--resample {args.resample}: the spacing must be > 0 s")
    return {"time": _spec(args.time), "input": _spec(args.input_column),
            "output": _spec(args.output_column), "run": _spec(args.run_column),
            "resample": resample}


def say_read(progress: Progress, recs: list[Any]) -> None:
    """Report each recording read (samples, time axis, columns, cleaning notes) on stderr."""
    for r in recs:
        axis = f"t = {r.t[0]:g} .. {r.t[-1]:g} s" if r.has_time else "no time axis"
        progress(f"read {r.name}: {r.n_samples} samples, {axis}, "
                 f"u = {r.columns.get('input', 'u')}, y = {r.columns.get('output', 'y')}")
        for note in r.cleaning:
            progress(f"  note: {note}")


def add_model_option(p: argparse.ArgumentParser) -> None:
    """``--model KIND``: the fit kinds declared by the model registry (``fit_kinds()``)."""
    from core.models import DEFAULT_FIT_KIND, fit_kinds

    p.add_argument("--model", default=DEFAULT_FIT_KIND, choices=fit_kinds(),
                   help="model family to fit (default: %(default)s)")


def register(subparsers: Any) -> None:
    """Add the ``fit`` sub-command."""
    p = subparsers.add_parser(
        "fit",
        help="fit an invertible PI-family model to measured input/output recordings",
        description=(
            "Read one or more CSV recordings (core.csvio: delimiter, header, units and "
            "time/input/output columns are detected, a run/loop column splits a file into "
            "several recordings), fit the chosen model and save "
            "it as a parameter set with the fit report (train / held-out RMSE, inverse "
            "check) in its provenance. Without --train/--test the last 20 % of every "
            "recording is held out. Progress goes to stderr."
        ),
    )
    p.add_argument("files", nargs="+", metavar="FILE.csv", help="recording(s)")
    add_model_option(p)
    p.add_argument("-n", "--n-operators", type=int, metavar="N",
                   help="number of play operators (default: chosen by cross-validation)")
    p.add_argument("--constraint", choices=("nonnegative", "slopes"),
                   help="'nonnegative' weights (default; hardening loops such as piezo "
                        "actuators) or positive loop 'slopes' only (saturating loops: B-H, "
                        "friction)")
    add_read_options(p)
    p.add_argument("--train", metavar="T0:T1",
                   help="fit only samples with T0 <= t < T1 (either side may be empty)")
    p.add_argument("--test", metavar="T0:T1",
                   help="held-out samples for the report, T0 <= t < T1")
    p.add_argument("--initial-memory", choices=("exclude", "keep"), default="exclude",
                   help="the memory state at the start of a recording is unknown: 'exclude' "
                        "(default) leaves the training rows before the wipe-out time (until "
                        "the input first reaches both ends of its range) out of the weight "
                        "fit; 'keep' fits them from the relaxed state (recordings that start "
                        "at rest). The PI model only; the report says what was done")
    p.add_argument("-o", "--output", required=True, metavar="MODEL.json",
                   help="where to write the fitted parameter set")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    add_json_flag(p)
    p.set_defaults(func=run)


def _estimator(name: str, n: int | None, constraint: str | None = None,
               initial_memory: str = "keep") -> Any:
    """The estimator of ``--model name`` (``None`` options left default)."""
    import inspect

    from core.models import estimator_class

    cls = estimator_class(name)
    kwargs: dict[str, Any] = {}
    if "initial_memory" in inspect.signature(cls).parameters:
        kwargs["initial_memory"] = initial_memory
    if constraint is not None:
        kwargs["constraint"] = constraint
    if n is not None:
        kwargs["n_operators"] = n
    return cls(**kwargs)


def run(args: argparse.Namespace) -> int:
    """Fit and save."""
    from core.paramset import ParameterSet

    progress = Progress("fit", quiet=args.quiet or args.json)
    train_w = parse_window(args.train, "train") if args.train else None
    test_w = parse_window(args.test, "test") if args.test else None
    if args.n_operators is not None and args.n_operators < 1:
        raise CommandError(f"-n must be a positive number of operators, got {args.n_operators}")
    from core.csvio import read_csv

    recs = []
    for f in args.files:
        existing_file(f, "CSV file")
        recs.extend(read_csv(Path(f), **read_kwargs(args)))
    say_read(progress, recs)
    us = [r.u for r in recs]
    ys = [r.y for r in recs]
    trains = [(r.t >= train_w[0]) & (r.t < train_w[1]) for r in recs] if train_w else []
    tests = [(r.t >= test_w[0]) & (r.t < test_w[1]) for r in recs] if test_w else []
    for lab, masks in (("--train", trains), ("--test", tests)):
        if masks and not any(m.any() for m in masks):
            raise CommandError(f"{lab} window selects no samples; check it against the t column")
    multi = len(recs) > 1
    est = _estimator(args.model, args.n_operators, args.constraint,
                     getattr(args, "initial_memory", "keep"))
    progress(f"fitting {args.model}" + (f" with n = {args.n_operators}" if args.n_operators
                                         else " (choosing n by cross-validation)"))
    kw: dict[str, Any] = {}
    if trains:
        kw["train"] = trains if multi else trains[0]
    if tests:
        kw["test"] = tests if multi else tests[0]
    with warnings.catch_warnings(record=True) as caught, progress.heartbeat("still fitting..."):
        warnings.simplefilter("always")
        est.fit(us if multi else us[0], ys if multi else ys[0], **kw)
    msgs = [str(w.message) for w in caught]
    for m in msgs:
        progress(f"warning: {m}")
    mem = est.report_.extra.get("initial_memory")
    if isinstance(mem, dict):
        progress(mem["summary"])
    model = est.full_model_
    report = est.report_.to_dict()
    first = recs[0]
    units = {
        "input": first.units.get("input") or "V",
        "output": first.units.get("output") or "um",
        "time": first.units.get("time") or "s",
    }
    fit_info = {
        "model": args.model,
        "files": [Path(f).name for f in args.files],
        "recordings": [r.name for r in recs],
        "columns": {k: first.columns.get(k, "") for k in ("time", "input", "output")},
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
    emit(args, f"{est.report_.summary()}\nwrote {path}",
         {"output": str(path), "model": ps.model.to_dict(), "units": units, "report": report,
          "warnings": msgs})
    return 0
