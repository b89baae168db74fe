"""``hyst diagnose FILE.csv [FILE.csv ...]``: find the physics a PI model leaves out.

Fits a PI baseline on the training rows, maps where the residual lives (LOCATE), fits every
testable effect of :mod:`core.stages` in full and keeps those that improve the held-out fit
significantly (SAY / MODEL / SHOW); effects the recordings cannot excite are reported as
untestable, look-alikes that the recordings cannot separate as ambiguous.

``--json`` prints ONE JSON object on stdout (:meth:`core.diagnosis.DiagnosisResult.to_dict`)::

    {
      "format": "hysteresis-explorer/diagnosis", "version": 1,
      "recordings": [{"name", "samples", "dt_s"}], "split": "...",
      "baseline": {"model": "pi", "n_operators", "heldout_rmse", "heldout_rmse_pct",
                   "per_recording", "noise_rms", "ljung_box", "model_dict", "maps"},
      "effects": [{"name": "lag", "parameters": {"tau_s": ...}, "uncertainty": {...},
                   "where": {"time_windows", "input_range", "branch", "summary", ...},
                   "explanation": "...", "equation": "...",
                   "heldout_rmse_before": ..., "heldout_rmse_after": ..., "dm_z": ...,
                   "signed_rank_p": ..., "heldout_mse_reduction": ..., "ambiguous_with": [...],
                   "crossfit": {"folds", "dm_z_pooled", "signed_rank_p_pooled",
                                "fold_mse_reductions", "parameter_cv", ...} or null, ...}],
      "untestable": [{"name", "reason", "experiment"}],
      "ambiguous": [{"effects", "chosen", "reason", "experiment"}],
      "final": {"effects", "heldout_rmse", "heldout_rmse_pct", "per_recording", "model", "maps"},
      "tested": [{"round", "effect", "heldout_mse_reduction", "dm_z", "signed_rank_p",
                  "passes", "decision", "parameters", "evidence", "reasons", ...}],
      "between_recordings": {"rate": {"tested", "reason"}, "amplitude": {"tested", "reason"}},
      "accept_rule": {...}, "elapsed_s": ...
    }

RMSE values are in output units; ``*_pct`` in % of the output range of the scored rows (the
held-out rows; every row for leave-one-recording-out), as in the ``hyst fit`` report.
``--save-model`` writes a parameter set (``hysteresis-explorer/parameter-set`` v1) whose model
is the extended chain fitted to the first recording, so ``hyst simulate`` predicts new inputs
with the accepted effects.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from app.services.analysis.diagnosis import (
    diagnose_files,
    diagnosis_json,
    diagnosis_source,
    save_model,
)
from app.services.runs.progress import Progress
from core.diagnosis.data import TimeGapError
from core.exceptions import ParameterError

from ._common import add_threads_option, window_arg
from ._scale import DIAGNOSE, ETA_FROM_S, EtaProgress, check_memory, count_samples
from .fit import add_read_options, read_options

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``diagnose`` sub-command."""
    p = subparsers.add_parser(
        "diagnose",
        help="find the physics a PI model leaves out (delay, lag, creep, drift, ...)",
        description=(
            "Fit a PI model, locate where it and the recordings differ, name the missing "
            "physics (delay, lag, resonance, rate, creep, drift, asymmetry, offset, "
            "initial-memory, saturation, dead-zone), fit it and show the held-out improvement. "
            "CSV files are "
            "read like hyst fit (core.csvio: delimiter, decimal mark, units and columns "
            "detected; a run/loop column splits a file; files without a time axis are "
            "diagnosed for the rate-independent effects). Progress goes to stderr."
        ),
    )
    p.add_argument("files", nargs="+", metavar="FILE.csv", help="recordings")
    p.add_argument("--model", default="pi", choices=["pi"], help="base model (default: pi)")
    p.add_argument("--base", default="auto", choices=["auto", "pi"],
                   help="base hysteresis the effects are judged against: 'auto' (default) "
                   "replaces the PI by a Preisach model (level-dependent memory) when that "
                   "predicts each recording from the others clearly better, also than a PI "
                   "with a static output map; 'pi' keeps the PI")
    add_read_options(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress on stderr")
    p.add_argument("--train", type=window_arg("train"), metavar="T0:T1",
                   help="training time range (s)")
    p.add_argument("--test", type=window_arg("test"), metavar="T0:T1",
                   help="held-out time range (s)")
    p.add_argument("--operators", type=int, default=25, metavar="N",
                   help="play operators of the baseline (default: 25)")
    p.add_argument("--fixed-grid", action="store_true",
                   help="keep exactly --operators plays (no automatic grid refinement)")
    p.add_argument("--no-crossfit", action="store_true",
                   help="with --train/--test, judge significance on the test rows only (by "
                   "default the training window's cross-fitted blocks are added)")
    p.add_argument("--effects", metavar="LIST",
                   help="comma-separated effects to test (default: all)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object on stdout instead of the readable report")
    p.add_argument("--save-model", metavar="MODEL.json",
                   help="write the extended model as a parameter set for hyst simulate")
    p.add_argument("--report", metavar="REPORT.html",
                   help="write a self-contained HTML report (loops, maps, effects)")
    add_threads_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Run the diagnosis and print the report (or JSON)."""
    # the size first: refuse up front what cannot fit, and say how long a long one takes
    samples = count_samples(args.files)
    what = args.files[0] if len(args.files) == 1 else f"the {len(args.files)} files"
    check_memory(samples, DIAGNOSE, what)
    expected = DIAGNOSE.cpu_s(samples)
    if expected >= ETA_FROM_S:
        progress: Progress = EtaProgress("diagnose", expected, quiet=args.quiet)
        progress(f"{what}: about {samples:,} samples, expected to take about "
                 f"{expected:.0f} s on one free core")
    else:
        progress = Progress("diagnose", quiet=args.quiet)
    try:
        res = diagnose_files(args.files, read_options(args), progress, model=args.model,
                             base=args.base, train=args.train, test=args.test,
                             operators=args.operators, fixed_grid=args.fixed_grid,
                             no_crossfit=args.no_crossfit, effects=args.effects)
    except TimeGapError as exc:  # say how to resample with this command's own options
        raise ParameterError(
            f"{exc}: run hyst diagnose FILE.csv --resample (onto the usual spacing of "
            f"{exc.spacing_s:.6g} s), or --resample=DT for a step of DT seconds"
        ) from None
    if args.save_model:
        p = save_model(res, args.save_model, source=diagnosis_source(args.files))
        print(f"wrote {p}", file=sys.stderr)
    if args.report:
        from app.services.analysis.diagnosis_report import write_report

        p = write_report(res, args.report)
        print(f"wrote {p}", file=sys.stderr)
    if args.json:
        print(diagnosis_json(res))
    else:
        print(res.summary())
    return 0
