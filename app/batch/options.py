"""What a batch runs on every recording: the options of ``hyst fit`` or ``hyst diagnose``.

Each options class turns itself into the argument list of the single-file command, and the
command's own parser checks it (:func:`command_args`), so a batch accepts exactly what the
single-file command accepts and reports bad options before any work starts.
"""

from __future__ import annotations

import argparse
import hashlib
import json
from dataclasses import asdict, dataclass
from types import ModuleType
from typing import ClassVar

from ..commands._common import CommandError, parse_window

__all__ = ["DiagnoseOptions", "FitOptions", "Options", "command_args", "command_module"]


class _RaisingParser(argparse.ArgumentParser):
    """An argparse parser that raises :class:`CommandError` instead of exiting."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise CommandError(message)


def command_module(kind: str) -> ModuleType:
    """The single-file command module of ``kind`` (``"fit"`` or ``"diagnose"``)."""
    if kind == "fit":
        from ..commands import fit

        return fit
    if kind == "diagnose":
        from ..commands import diagnose

        return diagnose
    raise CommandError(f"unknown batch kind {kind!r}; use 'fit' or 'diagnose'")


def command_args(kind: str, argv: list[str]) -> argparse.Namespace:
    """Parse ``hyst <kind> argv...`` with the single-file command's own parser.

    Raises
    ------
    CommandError
        With argparse's message when an option is invalid.
    """
    parser = _RaisingParser(prog="hyst", add_help=False)
    sub = parser.add_subparsers(dest="command")
    command_module(kind).register(sub)
    return parser.parse_args([kind, *argv])


@dataclass(frozen=True)
class _Options:
    kind: ClassVar[str]

    def argv(self) -> list[str]:  # pragma: no cover - overridden
        raise NotImplementedError

    def key(self) -> str:
        """Hash of the kind and every option (part of the resume key)."""
        text = json.dumps({"kind": self.kind, **asdict(self)}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def validate(self) -> None:
        """Check the options with the single-file command's parser and window rule (raises
        CommandError)."""
        for what in ("train", "test"):
            text = getattr(self, what)
            if text is not None:
                parse_window(text, what)
        command_args(self.kind, ["recording.csv", *self.argv(), *_OUTPUT_ARGS[self.kind]])

    def to_dict(self) -> dict[str, object]:
        return {"kind": self.kind, **asdict(self)}


_OUTPUT_ARGS = {"fit": ["-o", "model.json"], "diagnose": ["--save-model", "model.json"]}


def _opt(flag: str, value: object) -> list[str]:
    return [] if value is None else [flag, str(value)]


@dataclass(frozen=True)
class FitOptions(_Options):
    """Options of ``hyst fit`` applied to every recording (``None``: the command's default).

    Parameters
    ----------
    model : str
        ``--model``: one of :func:`core.models.fit_kinds` (``pi`` by default).
    n_operators : int or None
        ``-n``: play operators (default: chosen by cross-validation).
    constraint : str or None
        ``--constraint``: ``nonnegative`` or ``slopes``.
    time, input_column, output_column : str or None
        Column names or 0-based indices.
    train, test : str or None
        ``T0:T1`` windows in seconds.
    """

    kind: ClassVar[str] = "fit"
    model: str = "pi"
    n_operators: int | None = None
    constraint: str | None = None
    time: str | None = None
    input_column: str | None = None
    output_column: str | None = None
    train: str | None = None
    test: str | None = None

    def argv(self) -> list[str]:
        """The ``hyst fit`` options (without the file and ``-o``)."""
        return [
            "--model", self.model, *_opt("-n", self.n_operators),
            *_opt("--constraint", self.constraint), *_opt("--time", self.time),
            *_opt("--input-column", self.input_column),
            *_opt("--output-column", self.output_column),
            *_opt("--train", self.train), *_opt("--test", self.test),
        ]


@dataclass(frozen=True)
class DiagnoseOptions(_Options):
    """Options of ``hyst diagnose`` applied to every recording.

    Parameters
    ----------
    operators : int
        ``--operators`` of the PI baseline (default 25).
    fixed_grid : bool
        ``--fixed-grid``: no automatic grid refinement.
    no_crossfit : bool
        ``--no-crossfit``.
    effects : str or None
        ``--effects``: comma-separated effects to test (default: all).
    train, test : str or None
        ``T0:T1`` windows in seconds.
    """

    kind: ClassVar[str] = "diagnose"
    operators: int = 25
    fixed_grid: bool = False
    no_crossfit: bool = False
    effects: str | None = None
    train: str | None = None
    test: str | None = None

    def argv(self) -> list[str]:
        """The ``hyst diagnose`` options (without the file, ``--json`` and ``--save-model``)."""
        return [
            "--operators", str(self.operators), *(["--fixed-grid"] if self.fixed_grid else []),
            *(["--no-crossfit"] if self.no_crossfit else []),
            *_opt("--effects", self.effects), *_opt("--train", self.train),
            *_opt("--test", self.test),
        ]


Options = FitOptions | DiagnoseOptions
