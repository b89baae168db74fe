"""``hyst export MODEL.json --format json|mat|c --output PATH``: parameter sets for real use."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from core.exceptions import NotInvertibleError

from ..services.inputs import CommandError
from ._common import add_json_flag, emit, read_parameter_set

__all__ = ["FORMATS", "register", "run"]

FORMATS = ("json", "mat", "c")


def register(subparsers: Any) -> None:
    """Add the ``export`` sub-command."""
    p = subparsers.add_parser(
        "export",
        help="export a model as a parameter set (json), MATLAB .mat or C99 compensator code",
        description=(
            "json: the validated, versioned parameter-set document (also turns a bare model "
            "into one). mat: MATLAB structs (model, inverse, units) plus the JSON text. "
            "c: C99 header + source with the inverse compensator <name>_inv_step() and the "
            "forward model <name>_fwd_step(), no allocation, state in a struct."
        ),
    )
    p.add_argument("model", metavar="MODEL.json", help="parameter set (or bare model)")
    p.add_argument("-f", "--format", required=True, choices=FORMATS, help="output format")
    p.add_argument("-o", "--output", required=True, metavar="PATH",
                   help="output file (c: PATH.c and PATH.h are written)")
    p.add_argument("--name", help="C: identifier prefix (default: from the output file name)")
    p.add_argument("--no-forward", action="store_true",
                   help="C: emit only the inverse compensator")
    p.add_argument("--no-inverse", action="store_true",
                   help="C: emit only the forward model (for non-invertible models)")
    p.add_argument("--dt", type=float, help="C: sample time in s baked into dynamic stages")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Export ``args.model`` in ``args.format``."""
    ps = read_parameter_set(args.model)
    out = Path(args.output)
    if args.format == "json":
        written = [ps.save(out)]
    elif args.format == "mat":
        from core.export_mat import export_mat

        written = [export_mat(ps, out)]
    else:
        from core.export_c import export_c

        if args.no_forward and args.no_inverse:
            raise CommandError("--no-forward and --no-inverse together leave nothing to export")
        try:
            written = list(
                export_c(ps, out, name=args.name, inverse=not args.no_inverse,
                         forward=not args.no_forward, dt=args.dt)
            )
        except NotInvertibleError as exc:
            raise NotInvertibleError(
                f"{exc}; use --no-inverse to export only the forward model"
            ) from exc
    names = ", ".join(str(w) for w in written)
    emit(args, f"wrote {names}", {"format": args.format, "files": [str(w) for w in written]})
    return 0
