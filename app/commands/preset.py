"""``hyst preset NAME --output MODEL.json`` and ``hyst preset --list``: the papers' examples."""

from __future__ import annotations

import argparse
from collections.abc import Mapping
from typing import Any

from ._common import CommandError, add_json_flag, emit

__all__ = ["available_presets", "load_preset", "register", "run"]

#: Used only while ``core/presets.py`` does not exist: paper 001, Example 1.
_BUILTIN = {
    "paper001-example1": (
        "Paper 001 Example 1: classical PI, r_i = 0.45 i (i = 1..6), p0 = 0.72, "
        "p = 0.6, 0.48, 0.36, 0.24, 0.12, 0.012",
        {
            "type": "pi",
            "p0": 0.72,
            "thresholds": [0.45, 0.9, 1.35, 1.8, 2.25, 2.7],
            "weights": [0.6, 0.48, 0.36, 0.24, 0.12, 0.012],
        },
    ),
}


def _presets_module() -> Any:
    import importlib

    try:
        return importlib.import_module("core.presets")
    except ModuleNotFoundError as exc:
        if exc.name != "core.presets":
            raise
        return None


def _text(obj: Any, *keys: str) -> str:
    for k in keys:
        v = obj.get(k) if isinstance(obj, Mapping) else getattr(obj, k, None)
        if isinstance(v, str) and v:
            return v
    return ""


def available_presets() -> list[dict[str, str]]:
    """``{"name", "title", "description"}`` of every preset, in the order to show them."""
    mod = _presets_module()
    if mod is None:
        return [{"name": k, "title": v[0], "description": ""} for k, v in _BUILTIN.items()]
    out = []
    for it in mod.list_presets():
        if isinstance(it, str):
            out.append({"name": it, "title": "", "description": ""})
        else:
            out.append({"name": _text(it, "name"), "title": _text(it, "title"),
                        "description": _text(it, "description")})
    return out


def load_preset(name: str) -> Any:
    """The named preset as a :class:`~core.paramset.ParameterSet`.

    Raises
    ------
    CommandError
        Unknown name (the message lists the known presets).
    """
    from core.base import Model
    from core.paramset import ParameterSet, load_parameter_set, model_from_document

    infos = {p["name"]: p for p in available_presets()}
    if name not in infos:
        raise CommandError(
            f"unknown preset {name!r}; known presets: {', '.join(infos)} (see hyst preset --list)"
        )
    mod = _presets_module()
    desc = infos[name]["title"] or infos[name]["description"] or f"preset {name}"
    if mod is None:
        return ParameterSet.from_model(
            model_from_document(_BUILTIN[name][1]), source=f"hyst preset {name}: {desc}"
        )
    obj = mod.get_preset(name)
    if isinstance(obj, ParameterSet):
        return obj
    if isinstance(obj, Model):
        return ParameterSet.from_model(obj, source=f"hyst preset {name}: {desc}")
    if isinstance(obj, Mapping):
        if "format" in obj:
            return load_parameter_set(obj)
        return ParameterSet.from_model(
            model_from_document(obj), source=f"hyst preset {name}: {desc}"
        )
    raise CommandError(f"preset {name!r} has an unexpected form ({type(obj).__name__})")


def register(subparsers: Any) -> None:
    """Add the ``preset`` sub-command."""
    p = subparsers.add_parser(
        "preset",
        help="write one of the papers' example models as a parameter set, or list them",
        description="Write a built-in example model (from the papers) as a parameter set.",
    )
    p.add_argument("name", nargs="?", metavar="NAME", help="preset name (see --list)")
    p.add_argument("--list", action="store_true", help="list the presets and exit")
    p.add_argument("-o", "--output", metavar="MODEL.json", help="where to write the preset")
    add_json_flag(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """List presets or write one."""
    if args.list:
        items = available_presets()
        width = max(len(p["name"]) for p in items)
        text = "\n".join(
            f"{p['name']:<{width}}  {p['title'] or p['description']}" for p in items
        )
        emit(args, text, {"presets": items})
        return 0
    if not args.name:
        raise CommandError("give a preset NAME (and --output MODEL.json), or --list")
    if not args.output:
        raise CommandError(f"give --output MODEL.json to write preset {args.name!r}")
    ps = load_preset(args.name)
    path = ps.save(args.output)
    emit(args, f"wrote {path}: preset {args.name} ({ps.model.to_dict()['type']})",
         {"output": str(path), "preset": args.name, "model": ps.model.to_dict()})
    return 0
