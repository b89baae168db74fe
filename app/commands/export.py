"""``hyst export MODEL.json --format json|mat|c|fmu --output PATH``: parameter sets for real use."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from app.services.runs.inputs import CommandError
from core.exceptions import NotInvertibleError

from ._common import add_json_flag, add_threads_option, emit, read_parameter_set

__all__ = ["FORMATS", "register", "run"]

FORMATS = ("json", "mat", "c", "fmu")


def register(subparsers: Any) -> None:
    """Add the ``export`` sub-command."""
    p = subparsers.add_parser(
        "export",
        help="export a model as a parameter set (json), MATLAB .mat, C99 compensator code or "
        "an FMU (FMI 3.0/2.0 co-simulation)",
        description=(
            "json: the validated, versioned parameter-set document (also turns a bare model "
            "into one). mat: MATLAB structs (model, inverse, units) plus the JSON text. "
            "c: C99 header + source with the inverse compensator <name>_inv_step() and the "
            "forward model <name>_fwd_step(), no allocation, state in a struct. "
            "fmu: a co-simulation Functional Mock-up Unit compiled here with gcc (Simulink, "
            "OpenModelica, Dymola, fmpy, ...): the model (u -> y), or with --inverse the "
            "compensator (y_ref -> u); every parameter tunable in the importer."
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
    p.add_argument("--dt", type=float,
                   help="C, fmu: sample time in s baked into dynamic stages (required when the "
                   "model has dynamics)")
    p.add_argument("--fmi", default="3", metavar="3|2",
                   help="fmu: FMI version, 3 (FMI 3.0, default) or 2 (FMI 2.0)")
    p.add_argument("--inverse", action="store_true",
                   help="fmu: export the inverse compensator instead of the model")
    add_json_flag(p)
    add_threads_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Export ``args.model`` in ``args.format``."""
    ps = read_parameter_set(args.model)
    out = Path(args.output)
    if args.format != "fmu" and (args.inverse or args.fmi != "3"):
        raise CommandError(f"--inverse and --fmi are options of --format fmu, not of "
                           f"--format {args.format}")
    if args.format == "fmu":
        written = [_export_fmu(ps, out, args)]
    elif args.format == "json":
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
    if args.format == "fmu":
        emit(args, f"wrote {names} (FMI {args.fmi}.0 co-simulation, "
             f"{'inverse compensator' if args.inverse else 'model'})",
             {"format": "fmu", "fmi": f"{args.fmi}.0", "inverse": args.inverse,
              "files": [str(w) for w in written]})
        return 0
    emit(args, f"wrote {names}", {"format": args.format, "files": [str(w) for w in written]})
    return 0


def _export_fmu(ps: Any, out: Path, args: argparse.Namespace) -> Path:
    """Build the FMU of ``ps`` (options checked first, each error naming its option)."""
    from core.export_fmu import FMI_VERSIONS, build_fmu

    fmi = {"3": 3, "3.0": 3, "2": 2, "2.0": 2}.get(str(args.fmi).strip())
    if fmi is None:
        raise CommandError(
            f"--fmi {args.fmi}: unknown FMI version; use "
            + " or ".join(f"--fmi {v} (FMI {v}.0)" for v in FMI_VERSIONS)
        )
    args.fmi = str(fmi)
    if args.no_forward or args.no_inverse:
        raise CommandError("--no-forward/--no-inverse are C options; an FMU holds one "
                           "direction: the model, or the compensator with --inverse")
    if ps.model.is_dynamic and args.dt is None:
        raise CommandError(
            f"the {ps.model.type_name!r} model has dynamics, so its FMU runs at a fixed sample "
            "time: give it with --dt (seconds), e.g. --dt 1e-4"
        )
    if out.suffix.lower() != ".fmu":
        raise CommandError(f"--output {out}: an FMU file name ends in .fmu, e.g. "
                           f"--output {out.with_suffix('.fmu').name}")
    try:
        return build_fmu(ps, out, fmi_version=fmi, inverse=args.inverse, dt=args.dt,
                         name=args.name)
    except NotInvertibleError as exc:
        raise NotInvertibleError(
            f"{exc}; export the model itself (without --inverse)") from exc
