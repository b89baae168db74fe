"""``hyst invert MODEL.json --output INVERSE.json``: the exact inverse compensator."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import add_json_flag, emit, read_parameter_set

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``invert`` sub-command."""
    p = subparsers.add_parser(
        "invert",
        help="write the exact inverse (compensator) of a model as a parameter set",
        description=(
            "Compute the analytical inverse of a model (PI: paper 001 eq. 35-37; chains: the "
            "inverses of the stages in reverse order) and save it as a parameter set whose "
            "input/output units are swapped. Fails with a message naming the slope or rule "
            "when the model is not invertible."
        ),
    )
    p.add_argument("model", metavar="MODEL.json", help="parameter set (or bare model) to invert")
    p.add_argument("-o", "--output", required=True, metavar="INVERSE.json",
                   help="where to write the inverse parameter set")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Invert ``args.model`` into ``args.output``."""
    ps = read_parameter_set(args.model, require_inverse=True)
    inv = ps.inverse()
    path = inv.save(args.output)
    d = inv.model.to_dict()
    text = f"wrote {path}: inverse ({d['type']}) of {args.model}"
    if d["type"] == "pi":
        text += (
            f"\n  q0 = {d['p0']:.6g}\n  z  = {_fmt(d['thresholds'])}\n  q  = {_fmt(d['weights'])}"
        )
    emit(args, text, {"output": str(path), "model": d, "units": inv.units.to_dict()})
    return 0


def _fmt(values: list[float]) -> str:
    return "[" + ", ".join(f"{v:.6g}" for v in values) + "]"
