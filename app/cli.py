"""The ``hyst`` command line: discovers sub-commands in :mod:`app.commands`."""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from . import commands

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    """Parser with every sub-command module found in :mod:`app.commands`."""
    parser = argparse.ArgumentParser(
        prog="hyst",
        description="Hysteresis Explorer: Prandtl-Ishlinskii models, fitting, diagnosis, explorer.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for info in sorted(pkgutil.iter_modules(commands.__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"{commands.__name__}.{info.name}")
        mod.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``hyst``; returns the process exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    from core.threads import numeric_threads

    try:
        # the commands that compute run on one BLAS / OpenMP / numba thread unless --threads
        # asks for more (core.threads); the others (lists, lessons, serve and batch, whose
        # workers get one thread each) do not pay for loading the BLAS pools
        with numeric_threads(getattr(args, "threads", None)):
            return int(args.func(args) or 0)
    except KeyboardInterrupt:
        return 130
    except (ValueError, OSError) as exc:  # ParameterError & co. subclass ValueError
        print(f"hyst {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
