"""Named models from the papers' examples, for the CLI, the explorer and the examples.

``list_presets()`` describes every preset, ``get_preset(name)`` builds a fresh model.

Built in (paper 001, Al Janaideh et al. 2023):

* ``paper001-example1``: the classical PI model of Example 1, ``r_i = 0.45 i`` (i = 1..6),
  ``p0 = 0.72``, ``p = {0.6, 0.48, 0.36, 0.24, 0.12, 0.012}``.
* ``paper001-example1-m0=1`` / ``paper001-example1-m0=-1``: the same with every play
  operator starting at ``M0 = ±1`` (Fig. 9).
* ``paper001-example2``: the exact inverse of Example 1 (eq. 35-37).
* ``paper001-example2-approx``: the *estimated* model ``P̂`` of Example 2 (``r̂``, ``p̂``);
  its inverse is the approximate compensator ``P̂⁻¹``.

Paper 001 Examples 4 and 6 (``core.gpi``: dead-zone and tanh GPI) and the digitized models
of paper 000 (``core.digitized``) are presets too. Every preset inverts and exports (tested).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .base import Model
from .digitized import paper000_three_operators, paper000_two_operators
from .exceptions import ParameterError
from .gpi import paper001_example4, paper001_example6
from .pi import PIModel

__all__ = [
    "PAPER001_EX1",
    "PAPER001_EX2_APPROX",
    "PresetInfo",
    "get_preset",
    "list_presets",
]

#: Example 1 of paper 001: ``(p0, thresholds, weights)``.
PAPER001_EX1 = (0.72, tuple(0.45 * i for i in range(1, 7)), (0.6, 0.48, 0.36, 0.24, 0.12, 0.012))
#: The estimated parameters ``(p̂0, r̂, p̂)`` printed in paper 001 Example 2.
PAPER001_EX2_APPROX = (
    0.7536,
    (0.4678, 0.9178, 1.3678, 1.8178, 2.2678, 2.7178),
    (0.6192, 0.4835, 0.3637, 0.2464, 0.1410, 0.0184),
)


@dataclass(frozen=True)
class PresetInfo:
    """Description of one preset.

    Parameters
    ----------
    name : str
        Key for :func:`get_preset` (lower case, no spaces).
    title : str
        One-line title.
    description : str
        What the model is and where it comes from.
    """

    name: str
    title: str
    description: str


def _example1(m0: float | None = None) -> PIModel:
    p0, r, p = PAPER001_EX1
    return PIModel(p0, np.array(r), np.array(p), None if m0 is None else np.full(len(r), m0))


def _example2_approx() -> PIModel:
    p0, r, p = PAPER001_EX2_APPROX
    return PIModel(p0, np.array(r), np.array(p))


_BUILTIN: dict[str, tuple[str, str, Callable[[], Model]]] = {
    "paper001-example1": (
        "Paper 001 Example 1: classical PI, 6 operators",
        "r_i = 0.45 i (i = 1..6), p0 = 0.72, p = {0.6, 0.48, 0.36, 0.24, 0.12, 0.012}; "
        "slopes 0.72 ... 2.532, maximum loop width 1.518.",
        _example1,
    ),
    "paper001-example1-m0=1": (
        "Paper 001 Fig. 9: Example 1 with M0 = 1",
        "Example 1 with every play operator starting at M0 = 1; the offset is erased once "
        "the input has risen past r_6 + 1 = 3.7.",
        lambda: _example1(1.0),
    ),
    "paper001-example1-m0=-1": (
        "Paper 001 Fig. 9: Example 1 with M0 = -1",
        "Example 1 with every play operator starting at M0 = -1.",
        lambda: _example1(-1.0),
    ),
    "paper001-example2": (
        "Paper 001 Example 2: exact inverse of Example 1",
        "Inverse PI model (eq. 35-37): z = {0.324, 0.918, 1.728, 2.7, 3.78, 4.914}, "
        "q0 = 1.3889, q = {-0.6313, ..., -0.0019}.",
        lambda: _example1().inverse(),
    ),
    "paper001-example2-approx": (
        "Paper 001 Example 2: estimated model P̂",
        "The perturbed estimate r̂ = {0.4678, ..., 2.7178}, p̂0 = 0.7536, "
        "p̂ = {0.6192, ..., 0.0184}; its inverse is the approximate compensator.",
        _example2_approx,
    ),
}

_BUILTIN.update({
    "paper001-example4": (
        "Paper 001 Example 4: dead-zone GPI",
        "Generalized PI y = P[γ[v]] with 23 mirrored dead zones and "
        "p_i = 0.65 exp(-7.75e-4 r_i).",
        paper001_example4,
    ),
    "paper001-example6": (
        "Paper 001 Example 6: tanh-envelope GPI",
        "Example 4's PI after the envelope κ(v) = 6 tanh(0.4 v).",
        paper001_example6,
    ),
    "paper000-two-operators": (
        "Paper 000: digitized PI, two operators",
        "Digitized representation of a PI model with two play operators (paper 000 Fig. 3).",
        paper000_two_operators,
    ),
    "paper000-three-operators": (
        "Paper 000: digitized PI, three operators",
        "Digitized representation of a PI model with three play operators.",
        paper000_three_operators,
    ),
})


def list_presets() -> list[PresetInfo]:
    """Every preset, paper 001 first.

    Returns
    -------
    list of PresetInfo
    """
    return [PresetInfo(name, title, desc) for name, (title, desc, _) in _BUILTIN.items()]


def get_preset(name: str) -> Model:
    """Build the model of preset ``name`` (a new object on every call).

    Raises
    ------
    ParameterError
        If ``name`` is unknown; the message lists the valid names.
    """
    reg = _BUILTIN
    entry = reg.get(name)
    if entry is None:
        raise ParameterError(f"unknown preset {name!r}; valid presets: {', '.join(reg)}")
    model = entry[2]()
    if not isinstance(model, Model):
        raise ParameterError(f"preset {name!r} factory returned {type(model).__name__}, "
                             "not a Model")
    return model
