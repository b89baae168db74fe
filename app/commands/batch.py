"""``hyst batch fit|diagnose FILES... --output DIR``: many recordings on Dask.

Every recording runs through the single-file command (``hyst fit`` / ``hyst diagnose
--save-model``) on a Dask worker; ``DIR/<name>.json`` is what that command writes for it.
``DIR/summary.csv`` has one row per recording, ``DIR/report.html`` is the fleet report.
Exit code 0 when every recording succeeded, 1 when some failed (they are listed in the
summary with their errors), 2 for bad options.
"""

from __future__ import annotations

import argparse
import json
import os
from typing import Any

from ._common import add_json_flag

__all__ = ["register"]


def _positive(what: str) -> Any:
    def convert(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be a whole number, got {text!r}") \
                from None
        if v < 1:
            raise argparse.ArgumentTypeError(f"{what} must be at least 1, got {v}")
        return v

    return convert


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="+", metavar="FILE",
                   help="CSV recordings, folders (their *.csv) or quoted glob patterns "
                        "('data/**/*.csv')")
    p.add_argument("-o", "--output", required=True, metavar="DIR",
                   help="output folder: <name>.json per recording, summary.csv, report.html")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="address of a running Dask scheduler (default: start a local cluster)")
    p.add_argument("--workers", type=_positive("--workers"), default=os.cpu_count() or 1,
                   metavar="N", help="local worker processes, one thread each (default: one "
                   "per CPU); ignored with --scheduler")
    p.add_argument("--no-resume", action="store_true",
                   help="rerun every recording (default: skip those done before with the same "
                        "file content and options)")
    p.add_argument("--title", help="heading of the fleet report")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    add_json_flag(p)
    p.add_argument("--train", metavar="T0:T1", help="training time window (s), as in the "
                   "single-file command")
    p.add_argument("--test", metavar="T0:T1", help="held-out time window (s)")
    p.add_argument("--fmu", type=int, metavar="3|2",
                   help="also build each recording's FMU (FMI 3 or 2; the compensator, or the "
                        "model when it has no inverse) into DIR/fmu/, linked from the report")


def register(subparsers: Any) -> None:
    """Add ``batch fit`` and ``batch diagnose``."""
    from .fit import add_model_option

    p = subparsers.add_parser(
        "batch", help="fit or diagnose many recordings on Dask (local or a cluster)",
        description=__doc__.splitlines()[0].strip("`"))
    sub = p.add_subparsers(dest="batch_command", metavar="{fit,diagnose}", required=True)
    f = sub.add_parser("fit", help="hyst fit on every recording",
                       description="Run hyst fit on every recording (options as in hyst fit).")
    _common(f)
    add_model_option(f)
    f.add_argument("-n", "--n-operators", type=_positive("-n"), metavar="N",
                   help="play operators (default: chosen by cross-validation per recording)")
    f.add_argument("--constraint", choices=("nonnegative", "slopes"),
                   help="weight constraint, as in hyst fit")
    f.add_argument("--time", metavar="COL", help="time column (name or 0-based index)")
    f.add_argument("--input-column", metavar="COL", help="input column")
    f.add_argument("--output-column", metavar="COL", help="output column")
    f.set_defaults(func=run)
    d = sub.add_parser("diagnose", help="hyst diagnose --save-model on every recording",
                       description="Run hyst diagnose --save-model on every recording "
                                   "(options as in hyst diagnose).")
    _common(d)
    d.add_argument("--operators", type=_positive("--operators"), default=25, metavar="N",
                   help="play operators of the PI baseline (default: 25)")
    d.add_argument("--fixed-grid", action="store_true", help="no automatic grid refinement")
    d.add_argument("--no-crossfit", action="store_true",
                   help="with --train/--test, judge significance on the test rows only")
    d.add_argument("--effects", metavar="LIST", help="comma-separated effects to test")
    d.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the batch; print a one-line summary (or ``--json``) on stdout."""
    from app.batch import DiagnoseOptions, FitOptions, run_batch

    if args.batch_command == "fit":
        opts: FitOptions | DiagnoseOptions = FitOptions(
            model=args.model, n_operators=args.n_operators, constraint=args.constraint,
            time=args.time, input_column=args.input_column, output_column=args.output_column,
            train=args.train, test=args.test, fmu=args.fmu)
    else:
        opts = DiagnoseOptions(operators=args.operators, fixed_grid=args.fixed_grid,
                               no_crossfit=args.no_crossfit, effects=args.effects,
                               train=args.train, test=args.test, fmu=args.fmu)
    res = run_batch(args.files, args.output, opts, scheduler=args.scheduler,
                    workers=args.workers, resume=not args.no_resume,
                    quiet=args.quiet or args.json, report_title=args.title)
    if args.json:
        print(json.dumps({
            "output": str(res.output), "summary": str(res.summary_csv),
            "report": str(res.report_html), "elapsed_s": res.elapsed_s,
            "recordings": [r.to_dict() for r in res.recordings]}, indent=2, default=str))
    else:
        print(f"{len(res.succeeded)} ok ({len(res.resumed)} resumed), {len(res.failed)} "
              f"failed in {res.elapsed_s:.1f} s; see {res.summary_csv} and {res.report_html}")
    return 1 if res.failed else 0
