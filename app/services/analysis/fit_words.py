"""A fit in the explorer's words: what the page says after a fit (no viser / fastapi imports).

The fit's report is written for ``hyst fit`` (its options, ``hyst diagnose``); the page has
a fit menu and a *Run diagnosis* button instead, and a person reads the model types in
words (:func:`app.services.words.in_words`), never their names.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from app.services.words import in_words, type_words

if TYPE_CHECKING:
    from core.fitting import FitOutcome

__all__ = ["FitWords", "fit_words", "page_words"]

#: ``hyst fit`` / ``hyst diagnose`` phrases -> the page's controls.
_COMMANDS = (
    (re.compile(r"--model auto\b"), "the fit menu's automatic choice"),
    (re.compile(r"\bfit --model (\S+?)([,;.)]?)(?=\s|$)"), r"choose \1 in the fit menu\2"),
    (re.compile(r"--model (\S+?)([,;.)]?)(?=\s|$)"), r"\1 (fit menu)\2"),
    (re.compile(r"--constraint slopes"), "with weights of either sign"),
    # (the page holds out the last 20 %: other windows and memory rules are the command's)
    (re.compile(r"choose --train and --test windows"),
     "fit the file with the command line's hyst fit and its --train and --test windows"),
    (re.compile(r"(?<!hyst fit )--initial-memory keep"),
     "the command line's hyst fit --initial-memory keep"),
    (re.compile(r"\bhyst diagnose\b"), "the diagnosis (Run diagnosis)"),
    (re.compile(r"\bmin_slope\b"), "minimum slope"),
)


def page_words(text: str) -> str:
    """``text`` of a fit report in the page's words: the model types in words, the command
    line's options as the page's controls, and advice the page cannot follow (other
    held-out windows, the initial-memory rule) as the command line's."""
    for pattern, repl in _COMMANDS:
        text = pattern.sub(repl, text)
    return in_words(text)


@dataclass(frozen=True)
class FitWords:
    """What the page says about a fit, in words.

    Attributes
    ----------
    model : str
        The fitted model type in words, and whether it was chosen automatically.
    heldout : str
        The held-out error (the rows the fit did not use), as ``hyst fit`` reports it.
    choice : str or None
        How the automatic choice chose (the candidates' cross-validated errors).
    memory : str or None
        How each recording starts (periodic steady state, or the unknown memory left out).
    warnings : tuple of str
        The fit's warnings.
    """

    model: str
    heldout: str
    choice: str | None
    memory: str | None
    warnings: tuple[str, ...]


def fit_words(out: FitOutcome, unit: str = "") -> FitWords:
    """The :class:`FitWords` of the fit ``out`` (``unit``: the output's unit in words)."""
    rep = out.report
    n = rep.extra.get("n_operators")
    model = type_words(out.kind) + ("" if n is None else f", {n} operators")
    choice = rep.extra.get("base_choice")
    if choice:
        model += ", chosen automatically"
    test = rep.test
    if test is None:
        heldout = "No rows were held out: the error below is on the rows the model was fitted on."
    else:
        heldout = (f"Held-out error (the last 20 % of each recording, not used by the fit): "
                   f"RMS {test.rmse:.4g}{f' {unit}' if unit else ''}, "
                   f"{test.rmse_pct:.3g} % of the range")
    return FitWords(model, heldout, page_words(str(choice)) if choice else None,
                    page_words(out.memory_note.removeprefix("initial memory: "))
                    if out.memory_note else None,
                    tuple(page_words(w) for w in out.warnings))
