"""``hyst diagnose FILE.csv [FILE.csv ...]``: find the physics a PI model leaves out.

Fits a PI baseline on the training rows, maps where the residual lives (LOCATE), fits every
testable effect of :mod:`core.effects` in full and keeps those that improve the held-out fit
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
      "tested": [...], "accept_rule": {...}, "elapsed_s": ...
    }

RMSE values are in output units; ``*_pct`` in % of the output range of all recordings.
``--save-model`` writes a parameter set (``hysteresis-explorer/parameter-set`` v1) whose model
is the extended chain fitted to the first recording, so ``hyst simulate`` predicts new inputs
with the accepted effects.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from ._common import window_arg

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``diagnose`` sub-command."""
    p = subparsers.add_parser(
        "diagnose",
        help="find the physics a PI model leaves out (delay, lag, creep, drift, ...)",
        description=(
            "Fit a PI model, locate where it and the recordings differ, name the missing "
            "physics (delay, lag, resonance, rate, creep, drift, asymmetry, offset, "
            "initial-memory), fit it and show the held-out improvement. CSV files: header "
            "row, columns time (s), input, output."
        ),
    )
    p.add_argument("files", nargs="+", metavar="FILE.csv", help="recordings")
    p.add_argument("--model", default="pi", choices=["pi"], help="base model (default: pi)")
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
    p.set_defaults(func=run)


def _units(path: str) -> dict[str, str]:
    """Units from a header like ``t_s,u_V,y_um`` (defaults V, um, s)."""
    try:
        head = Path(path).read_text(encoding="utf-8", errors="replace").splitlines()[0]
    except (OSError, IndexError):
        return {"input": "V", "output": "um", "time": "s"}
    cols = [c.strip() for c in head.split(",")]

    def unit(c: str, default: str) -> str:
        return c.rsplit("_", 1)[1] if "_" in c else default

    return {
        "input": unit(cols[1], "V") if len(cols) > 1 else "V",
        "output": unit(cols[2], "um") if len(cols) > 2 else "um",
        "time": unit(cols[0], "s") if cols else "s",
    }


def save_model(result: Any, path: str | Path, units: dict[str, str], source: str) -> Path:
    """Write the final model of ``result`` as a parameter-set document."""
    summary = {
        "kind": "diagnosis",
        "effects": [e.name for e in result.effects],
        "heldout_rmse_baseline": result.heldout_rmse(result.baseline),
        "heldout_rmse_final": result.heldout_rmse(result.final),
        "split": result.split,
    }
    notes = "model fitted to the first recording; effects: " + (
        ", ".join(e.name for e in result.effects) or "none"
    )
    try:
        from core.paramset import ParameterSet

        try:
            ps = ParameterSet.from_model(result.model, units=units, source=source, fit=summary,
                                         notes=notes)
        except ValueError:  # units the parameter-set validator does not know
            ps = ParameterSet.from_model(result.model, source=source, fit=summary, notes=notes)
        return ps.save(path)
    except ImportError:  # pragma: no cover - paramset not available
        from datetime import UTC, datetime

        doc = {
            "format": "hysteresis-explorer/parameter-set",
            "version": 1,
            "model": result.model.to_dict(),
            "units": units,
            "provenance": {"created": datetime.now(UTC).isoformat(), "tool": "hyst diagnose",
                           "source": source, "fit": summary, "notes": notes},
        }
        p = Path(path)
        p.write_text(json.dumps(doc, indent=2), encoding="utf-8")
        return p


def run(args: argparse.Namespace) -> int:
    """Run the diagnosis and print the report (or JSON)."""
    from core.diagnosis import diagnose
    from core.exceptions import ParameterError

    for f in args.files:
        if not Path(f).is_file():
            raise ParameterError(f"recording {f!r} does not exist")
    effects = [e.strip() for e in args.effects.split(",")] if args.effects else None
    res = diagnose(list(args.files), model=args.model, train=args.train, test=args.test,
                   n_operators=args.operators, effects=effects,
                   auto_resolution=not args.fixed_grid,
                   crossfit=False if args.no_crossfit else None)
    if args.save_model:
        p = save_model(res, args.save_model, _units(args.files[0]),
                       source="hyst diagnose " + " ".join(Path(f).name for f in args.files))
        print(f"wrote {p}", file=sys.stderr)
    if args.report:
        from app.diagnosis_report import write_report

        p = write_report(res, args.report)
        print(f"wrote {p}", file=sys.stderr)
    if args.json:
        print(json.dumps(res.to_dict(), allow_nan=False))
    else:
        print(res.summary())
    return 0
