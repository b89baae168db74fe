"""What a batch runs on every recording: the options of ``hyst fit`` or ``hyst diagnose``.

Each options class checks itself with the single-file command's rules (:meth:`validate`:
fit kinds, constraints, ``T0:T1`` windows), so bad options are reported before any work
starts; the worker hands the options straight to :func:`core.fitting.fit_recordings` or
:func:`core.diagnosis.diagnose` (:mod:`app.batch.single`). :meth:`command_line` is the
equivalent single-file command, shown in the fleet report.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass
from typing import ClassVar

from app.services.runs.inputs import CommandError, parse_window

__all__ = ["DiagnoseOptions", "FitOptions", "Options"]


@dataclass(frozen=True)
class _Options:
    kind: ClassVar[str]

    def flags(self) -> list[str]:  # pragma: no cover - overridden
        raise NotImplementedError

    def command_line(self) -> str:
        """The equivalent single-file command, ``hyst <kind> FILE <options>`` (for display)."""
        return " ".join(["hyst", self.kind, "FILE", *self.flags()])

    def key(self) -> str:
        """Hash of the kind and every option (part of the resume key; ``fmu`` only when set,
        so the folders of earlier runs resume)."""
        opts = {k: v for k, v in asdict(self).items() if not (k == "fmu" and v is None)}
        text = json.dumps({"kind": self.kind, **opts}, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def validate(self) -> None:
        """Check the options with the single-file command's rules (raises CommandError)."""
        for what in ("train", "test"):
            text = getattr(self, what)
            if text is not None:
                parse_window(text, what)
        fmu = getattr(self, "fmu", None)
        if fmu is not None and fmu not in (3, 2):
            raise CommandError(f"--fmu {fmu!r}: unknown FMI version; use --fmu 3 or --fmu 2")
        self._check()

    def _check(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def to_dict(self) -> dict[str, object]:
        return {"kind": self.kind, **asdict(self)}


def _opt(flag: str, value: object) -> list[str]:
    return [] if value is None else [flag, str(value)]


@dataclass(frozen=True)
class FitOptions(_Options):
    """Options of ``hyst fit`` applied to every recording (``None``: the command's default).

    Parameters
    ----------
    model : str
        ``--model``: ``auto`` (the default, as ``hyst fit``: the base the diagnosis would
        choose, :func:`core.fitting.choice.choose_base`) or one of
        :func:`core.models.fit_kinds`.
    n_operators : int or None
        ``-n``: play operators (default: chosen by cross-validation).
    constraint : str or None
        ``--constraint``: ``nonnegative`` or ``slopes``.
    time, input_column, output_column : str or None
        Column names or 0-based indices.
    train, test : str or None
        ``T0:T1`` windows in seconds.
    fmu : {3, 2} or None
        Also build each recording's FMU of this FMI version (the compensator, or the model
        when it has no inverse), as ``hyst export --format fmu`` does.
    """

    kind: ClassVar[str] = "fit"
    model: str = "auto"
    n_operators: int | None = None
    constraint: str | None = None
    time: str | None = None
    input_column: str | None = None
    output_column: str | None = None
    train: str | None = None
    test: str | None = None
    fmu: int | None = None

    def _check(self) -> None:
        from app.services.analysis.fitting import check_n_operators
        from core.fitting.choice import AUTO
        from core.models import fit_kinds

        kinds = (AUTO, *fit_kinds())
        if self.model not in kinds:
            raise CommandError(f"--model {self.model!r}: choose one of {', '.join(kinds)}")
        check_n_operators(self.n_operators)
        if self.constraint not in (None, "nonnegative", "slopes"):
            raise CommandError(f"--constraint {self.constraint!r}: choose nonnegative or slopes")

    def flags(self) -> list[str]:
        """The ``hyst fit`` options (without the file and ``-o``), for display."""
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
    fmu : {3, 2} or None
        As for :class:`FitOptions`.
    """

    kind: ClassVar[str] = "diagnose"
    operators: int = 25
    fixed_grid: bool = False
    no_crossfit: bool = False
    effects: str | None = None
    train: str | None = None
    test: str | None = None
    fmu: int | None = None

    def _check(self) -> None:
        n = self.operators
        if isinstance(n, bool) or not isinstance(n, int) or n < 1:
            raise CommandError(f"--operators must be a positive integer, got {n!r}")

    def flags(self) -> list[str]:
        """The ``hyst diagnose`` options (without the file, ``--json`` and ``--save-model``),
        for display."""
        return [
            "--operators", str(self.operators), *(["--fixed-grid"] if self.fixed_grid else []),
            *(["--no-crossfit"] if self.no_crossfit else []),
            *_opt("--effects", self.effects), *_opt("--train", self.train),
            *_opt("--test", self.test),
        ]


Options = FitOptions | DiagnoseOptions
