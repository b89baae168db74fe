"""``hyst preset NAME --output MODEL.json`` and ``hyst preset --list``: the papers' examples."""

from __future__ import annotations

import argparse
from typing import Any

from app.services.runs.inputs import CommandError

from ._common import add_json_flag, emit

__all__ = ["available_presets", "load_preset", "register", "run"]


def available_presets() -> list[dict[str, str]]:
    """``{"name", "title", "description"}`` of every preset of :mod:`core.presets`."""
    from core.presets import list_presets

    return [{"name": p.name, "title": p.title, "description": p.description}
            for p in list_presets()]


def load_preset(name: str) -> Any:
    """The named preset as a :class:`~core.paramset.ParameterSet` (source = its title).

    Raises
    ------
    CommandError
        Unknown name (the message lists the known presets).
    """
    from core.paramset import ParameterSet
    from core.presets import get_preset

    infos = {p["name"]: p for p in available_presets()}
    if name not in infos:
        raise CommandError(
            f"unknown preset {name!r}; known presets: {', '.join(infos)} (see hyst preset --list)"
        )
    info = infos[name]
    return ParameterSet.from_model(
        get_preset(name), source=f"hyst preset {name}: {info['title']}",
        notes=info["description"] or None,
    )


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
