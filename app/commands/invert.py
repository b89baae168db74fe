"""``hyst invert MODEL.json --output INVERSE.json``: the exact inverse compensator."""

from __future__ import annotations

import argparse
from dataclasses import replace
from typing import Any

import numpy as np

from app.services.runs.inputs import CommandError

from ._common import add_json_flag, add_threads_option, emit, read_parameter_set

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``invert`` sub-command."""
    p = subparsers.add_parser(
        "invert",
        help="write the exact inverse (compensator) of a model as a parameter set",
        description=(
            "Compute the inverse of a model (PI: paper 001 eq. 35-37; chains: the inverses of "
            "the stages in reverse order; lag, creep, drift, offset, rate-dependent PI and "
            "initial memory exactly; a resonance with a roll-off at --bandwidth (error bound "
            "printed); an output map by bisection, clipped outside its range; a delay as an "
            "advance that needs a preview of the desired trajectory) and save it as a "
            "parameter set whose input/output units are swapped. Fails with a message naming "
            "the slope or rule when the model is not invertible."
        ),
    )
    p.add_argument("model", metavar="MODEL.json", help="parameter set (or bare model) to invert")
    p.add_argument("-o", "--output", required=True, metavar="INVERSE.json",
                   help="where to write the inverse parameter set")
    p.add_argument("--bandwidth", type=float, metavar="HZ",
                   help="roll-off frequency of resonance inverses (default: 4x the mode's "
                   "natural frequency)")
    p.add_argument("--dt", type=float, metavar="S",
                   help="sample time, to report the preview a delay inverse needs in samples")
    add_json_flag(p)
    add_threads_option(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Invert ``args.model`` into ``args.output``."""
    from core.base import Chain
    from core.stages import Advance, Resonance, ResonanceInverse

    if args.bandwidth is not None and not (np.isfinite(args.bandwidth) and args.bandwidth > 0):
        raise CommandError(f"--bandwidth must be a positive frequency in Hz, got {args.bandwidth}")
    if args.dt is not None and not (np.isfinite(args.dt) and args.dt > 0):
        raise CommandError(f"--dt must be a positive number of seconds, got {args.dt}")
    ps = read_parameter_set(args.model, require_inverse=True)
    inv = ps.inverse()
    if args.bandwidth is not None:
        stages = ps.model.stages if isinstance(ps.model, Chain) else (ps.model,)
        inv_stages = [s.inverse(bandwidth_hz=args.bandwidth) if isinstance(s, Resonance)
                      else s.inverse() for s in reversed(stages)]
        model = Chain(tuple(inv_stages)) if len(inv_stages) > 1 else inv_stages[0]
        inv = replace(inv, model=model)
    path = inv.save(args.output)
    d = inv.model.to_dict()
    text = f"wrote {path}: inverse ({d['type']}) of {args.model}"
    if d["type"] == "pi":
        text += (
            f"\n  q0 = {d['p0']:.6g}\n  z  = {_fmt(d['thresholds'])}\n  q  = {_fmt(d['weights'])}"
        )
    stages = inv.model.stages if isinstance(inv.model, Chain) else (inv.model,)
    notes: list[str] = []
    for s in stages:
        if isinstance(s, ResonanceInverse):
            notes.append(
                f"resonance at {s.freq_hz:g} Hz cancelled with a roll-off at {s.bandwidth_hz:g} "
                f"Hz: error <= 3 max|y''| / (2 pi {s.bandwidth_hz:g} Hz)^2, a sinusoid of "
                f"frequency f is reproduced within 3 (f / {s.bandwidth_hz:g} Hz)^2"
            )
        elif isinstance(s, Advance):
            need = (f"{s.preview_samples(args.dt)} sample(s) at dt = {args.dt:g} s"
                    if args.dt else f"{s.delay_s:g} s")
            notes.append(
                f"the model has a delay of {s.delay_s:g} s: the compensator needs the desired "
                f"trajectory {need} ahead (hyst simulate --inverse uses the known trajectory; "
                "the C export exposes <NAME>_INV_PREVIEW)"
            )
    text += "".join(f"\n  note: {n}" for n in notes)
    data = {"output": str(path), "model": d, "units": inv.units.to_dict(), "notes": notes}
    if args.dt:
        data["preview_samples"] = inv.model.preview_samples(args.dt)
    emit(args, text, data)
    return 0


def _fmt(values: list[float]) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in values) + "]"
