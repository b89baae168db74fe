"""``hyst fit FILE.csv ... --output MODEL.json``: identify a model from recordings."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from app.services.analysis.fitting import (
    check_n_operators,
    fit_errors,
    fit_source,
    say_fit,
    time_window,
)
from app.services.analysis.recordings import csv_read_options, read_recordings, say_read
from app.services.runs.progress import Progress

from ._common import add_json_flag, add_threads_option, emit
from ._scale import FIT, check_memory, count_samples

if TYPE_CHECKING:
    from core.csvio import CsvOptions

__all__ = ["add_model_option", "add_read_options", "read_options", "register", "run"]


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


def read_options(args: argparse.Namespace) -> CsvOptions:
    """The :class:`~core.csvio.CsvOptions` of :func:`add_read_options`."""
    return csv_read_options(args.time, args.input_column, args.output_column, args.run_column,
                            args.resample)


def add_model_option(p: argparse.ArgumentParser) -> None:
    """``--model KIND``: ``auto`` (the default: the base ``hyst diagnose`` would choose,
    :func:`core.fitting.choice.choose_base`) or one of the fit kinds declared by the model
    registry (``fit_kinds()``)."""
    from core.fitting.choice import AUTO
    from core.models import fit_kinds

    p.add_argument("--model", default=AUTO, choices=(AUTO, *fit_kinds()),
                   help="model family to fit; 'auto' (default) chooses the base as hyst "
                        "diagnose does (loop orientation, weight signs, and with several "
                        "recordings a Preisach or Bouc-Wen base or the PI with a static "
                        "output map where the loops saturate, each recording predicted "
                        "from the others on the training rows); the report says why")


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
    p.add_argument("--initial-memory", choices=("exclude", "keep"),
                   help="the memory state at the start of a recording is unknown: 'exclude' "
                        "(default for the pi and preisach models) leaves the training rows "
                        "before the wipe-out time (until the input first reaches both ends of "
                        "its range) out of the weight fit; 'keep' (what the other models do, "
                        "their only choice) fits them from the relaxed state (recordings that "
                        "start at rest). The report says what was done")
    p.add_argument("-o", "--output", required=True, metavar="MODEL.json",
                   help="where to write the fitted parameter set")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    add_json_flag(p)
    add_threads_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Fit and save."""
    from core.fitting import fit_recordings

    progress = Progress("fit", quiet=args.quiet or args.json)
    train_w = time_window(args.train, "train")
    test_w = time_window(args.test, "test")
    check_n_operators(args.n_operators)
    # refuse up front, with the memory it would need, what cannot fit
    check_memory(count_samples(args.files), FIT,
                 args.files[0] if len(args.files) == 1 else f"the {len(args.files)} files")
    recs = read_recordings(args.files, read_options(args))
    say_read(progress, recs)
    what = ("the base hyst diagnose would choose (--model auto)" if args.model == "auto"
            else args.model)
    progress(f"fitting {what}" + (f" with n = {args.n_operators}" if args.n_operators
                                  else " (choosing n by cross-validation)"))
    with fit_errors(), progress.heartbeat("still fitting..."):
        out = fit_recordings(recs, args.model, n_operators=args.n_operators,
                             constraint=args.constraint, train=train_w, test=test_w,
                             initial_memory=args.initial_memory, **fit_source(args.files))
    if args.model == "auto":
        progress(f"base chosen: {out.kind}")
    say_fit(progress, out)
    ps = out.parameter_set
    path = ps.save(args.output)
    progress(f"wrote {path}")
    emit(args, f"{out.summary()}\nwrote {path}",
         {"output": str(path), "model": ps.model.to_dict(), "units": ps.units.to_dict(),
          "report": out.report.to_dict(), "warnings": list(out.warnings)})
    return 0
