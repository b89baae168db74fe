"""What the diagnosis knows across effects: the order the families are disambiguated in, and
the rules read off the registry (the experiments that separate two look-alikes, which effects
need a time axis, which the recordings cannot test).

Each effect's own specification is its :class:`~core.diagnosis.registry.DiagnosableEffect`
in :data:`core.diagnosis.registry.EFFECTS`.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

from .registry import EFFECTS

__all__ = ["DECIDING_EXPERIMENT", "FAMILY_PRIORITY", "Untestable", "spec_untestable",
           "time_effects"]


@dataclass(frozen=True)
class Untestable:
    """An effect the recordings cannot test: the report's ``untestable`` entry.

    Attributes
    ----------
    name : str
        The effect's ``type`` (:data:`core.diagnosis.registry.EFFECTS`).
    reason : str
        Why the recordings cannot test it, in words.
    experiment : str
        The recording that would make it testable, in words.
    parameters : mapping of str to float
        What the recordings still say of it, when anything (a mode seen in the residual's
        spectrum: ``freq_hz``, Hz, and ``damping`` or its bound ``damping_below``); empty
        otherwise. Read-only (a copy of the mapping given, taken when the entry is made: an
        entry such as :data:`core.diagnosis.basechoice.RATE_ON_STOP` is shared by every
        run). Not in the report's JSON (:meth:`to_dict`), whose entry is
        ``{"name", "reason", "experiment"}``.
    """

    name: str
    reason: str
    experiment: str
    parameters: Mapping[str, float] = field(default_factory=lambda: MappingProxyType({}))

    def __post_init__(self) -> None:
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))

    def __reduce__(self) -> tuple[type[Untestable], tuple[str, str, str, dict[str, float]]]:
        # a read-only view does not pickle (nor deep-copy) itself: rebuilt from a plain copy
        return (Untestable, (self.name, self.reason, self.experiment, dict(self.parameters)))

    def to_dict(self) -> dict[str, str]:
        """The report's JSON entry ``{"name", "reason", "experiment"}``."""
        return {"name": self.name, "reason": self.reason, "experiment": self.experiment}


def spec_untestable(ctx: Any, already: set[str] | frozenset[str] = frozenset()
                    ) -> list[Untestable]:
    """The :class:`Untestable` entry of every effect whose own rule
    (:attr:`~core.diagnosis.registry.DiagnosableEffect.untestable`) says the recordings of
    ``ctx`` cannot test it (effects in ``already`` are skipped)."""
    out = []
    for name, e in EFFECTS.items():
        if e.untestable is None or name in already:
            continue
        why = e.untestable(ctx)
        if why:
            why, exp = why if isinstance(why, tuple) else (why, e.experiment or "")
            out.append(Untestable(name, why, exp))
    return out


class _DecidingExperiments(Mapping[frozenset[str], str]):
    """The deciding experiments of the registered effects by pair of names, read when
    asked (the effects register after this module is imported)."""

    def _table(self) -> dict[frozenset[str], str]:
        return {frozenset({n, other}): text for n, e in EFFECTS.items()
                for other, text in e.deciding}

    def __getitem__(self, pair: frozenset[str]) -> str:
        return self._table()[pair]

    def __iter__(self) -> Iterator[frozenset[str]]:
        return iter(self._table())

    def __len__(self) -> int:
        return len(self._table())


def time_effects() -> tuple[str, ...]:
    """Names of the effects that need a time axis."""
    return tuple(n for n, e in EFFECTS.items() if e.time_dependent)


#: The experiment that separates two look-alikes, by the pair of effect names: read off the
#: registry (each effect's :attr:`~core.diagnosis.registry.DiagnosableEffect.deciding`).
DECIDING_EXPERIMENT: Mapping[frozenset[str], str] = _DecidingExperiments()

#: Disambiguation order of the families (notes §4.3): cheapest and most common first.
FAMILY_PRIORITY: dict[str, int] = {
    "memory": 0, "dynamics": 1, "slow": 2, "static": 3, "static-offset": 3,
}

