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


def _describe(obj: Any) -> str:
    for attr in ("description", "title", "summary", "source"):
        v = getattr(obj, attr, None)
        if isinstance(v, str) and v:
            return v
    if isinstance(obj, Mapping):
        for key in ("description", "title", "source"):
            if isinstance(obj.get(key), str):
                return obj[key]
    return ""


def available_presets() -> list[tuple[str, str]]:
    """``(name, description)`` of every preset."""
    mod = _presets_module()
    if mod is None:
        return [(k, v[0]) for k, v in _BUILTIN.items()]
    items = mod.list_presets()
    out: list[tuple[str, str]] = []
    if isinstance(items, Mapping):
        for k, v in items.items():
            out.append((str(k), v if isinstance(v, str) else _describe(v)))
        return out
    for it in items:
        if isinstance(it, str):
            out.append((it, ""))
        elif isinstance(it, tuple | list) and len(it) >= 1:
            out.append((str(it[0]), str(it[1]) if len(it) > 1 else ""))
        else:
            name = getattr(it, "name", None)
            if name is None and isinstance(it, Mapping):
                name = it.get("name")
            out.append((str(name), _describe(it)))
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

    names = [n for n, _ in available_presets()]
    if name not in names:
        raise CommandError(
            f"unknown preset {name!r}; known presets: {', '.join(names)} (see hyst preset --list)"
        )
    mod = _presets_module()
    desc = dict(available_presets()).get(name) or f"preset {name}"
    if mod is None:
        return ParameterSet.from_model(
            model_from_document(_BUILTIN[name][1]), source=f"hyst preset {name}: {desc}"
        )
    obj = mod.get_preset(name)
    if isinstance(obj, ParameterSet):
        return obj
    if isinstance(obj, Model):
        return ParameterSet.from_model(obj, source=f"hyst preset {name}: {desc}")
    model = getattr(obj, "model", None)
    if isinstance(model, Model):
        units = getattr(obj, "units", None)
        return ParameterSet.from_model(
            model, units=units if isinstance(units, Mapping) else None,
            source=f"hyst preset {name}: {_describe(obj) or desc}",
        )
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
        width = max(len(n) for n, _ in items)
        text = "\n".join(f"{n:<{width}}  {d}" for n, d in items)
        emit(args, text, {"presets": [{"name": n, "description": d} for n, d in items]})
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
