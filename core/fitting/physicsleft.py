"""Which physics outside every rate-independent memory base the recordings show, in words.

When no base reaches the noise floor, two assumptions every play-, stop- or relay-based
base makes can be tested on the recordings themselves, without a model: that a repeated
input cycle gives the same loop every time (:mod:`core.fitting.cyclechange`: degradation or
hardening breaks it) and Masing's rule, that the branch after a reversal is the first
loading curve doubled (:mod:`core.fitting.masing`: a transition that changes with the
previous excursion, or a pinched loop, breaks it). :func:`physics_left` runs both; its
:meth:`PhysicsLeft.text` is the one sentence both the diagnosis's adequacy verdict
(:mod:`core.diagnosis.adequacy`) and ``hyst fit``'s misfit warning
(:mod:`core.fitting.entry`) say.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from ..recordings import Recording
from .cyclechange import CycleChange, cycle_change
from .masing import Masing, masing

__all__ = ["PhysicsLeft", "left_sentence", "physics_left", "physics_left_sentence"]


@dataclass(frozen=True)
class PhysicsLeft:
    """The two tests of a rate-independent memory base's assumptions.

    Attributes
    ----------
    cycle : CycleChange or None
        The loop's change under a repeated input cycle (``None``: no recording repeats
        enough identical cycles).
    masing : Masing
        Masing's rule on the recordings that start from rest.
    """

    cycle: CycleChange | None
    masing: Masing

    @property
    def found(self) -> bool:
        """Whether either test found physics the base cannot follow."""
        return (self.cycle is not None and self.cycle.changes) or self.masing.non_masing

    def text(self, units: dict[str, str] | None = None) -> str:
        """What the recordings show that no rate-independent memory base follows, in words
        (``""`` when neither test finds anything; ``units``: the recordings' ``"input"`` and
        ``"output"`` units)."""
        parts = []
        degrading = self.cycle is not None and self.cycle.changes
        if degrading and self.cycle is not None:
            parts.append(self.cycle.text())
        said = self.masing.text(units)
        if said:
            parts.append(said + ("; the loop's change from cycle to cycle above may be "
                                 "the same cause" if degrading else ""))
        return "; ".join(parts)


def physics_left(records: Sequence[Recording], noise: float) -> PhysicsLeft:
    """Both tests on ``records`` (module docstring).

    Parameters
    ----------
    records : sequence of Recording
    noise : float
        White-noise floor of the output (output units, RMS).
    """
    return PhysicsLeft(cycle_change(records, noise), masing(records, noise))


def physics_left_sentence(records: Sequence[Recording], noise: float) -> str:
    """:func:`physics_left`'s finding as a sentence of a misfit warning, in the recordings'
    units (``""`` when neither test finds anything): what ``hyst fit`` and the diagnosis's
    adequacy verdict both add after where the residual is largest."""
    return left_sentence(physics_left(records, noise).text(dict(records[0].units))
                         if records else "")


def left_sentence(text: str) -> str:
    """``text`` (:meth:`PhysicsLeft.text`) as the sentence both commands add, with its
    leading space; ``""`` for an empty ``text``."""
    return f" The recordings show physics no rate-independent base follows: {text}." if text \
        else ""
