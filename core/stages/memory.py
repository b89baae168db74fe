"""A hysteresis model started after a virtual input history (:class:`InitialMemory`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

from .._typing import Float1D
from ..base import Chain, Control, Field, Model, register_model
from ..exceptions import ParameterError
from ..pi import PIModel
from ..preisach import PreisachModel, RateDependentPreisach
from ..validation import as_vector, frozen
from .rate import RateDependentPI

#: Models made of a bank of play operators with ``thresholds`` and ``state0`` fields.
_PLAY_BANK_MODELS = (PIModel, RateDependentPI, PreisachModel, RateDependentPreisach)


@register_model
@dataclass(frozen=True, eq=False)
class InitialMemory(Model):
    """Initial memory: the memory at the first sample comes from a virtual input history.

    The PI memory is the alternating sequence of dominant past input extrema, so an unknown
    initial state is parametrised by a few virtual extrema ``history`` applied (quasi-
    statically) before the record starts (missing-physics notes, E8). The inverse is the
    inverse of the wrapped model started in the consistent state (the one reached by the
    output of the same history).

    Parameters
    ----------
    model : PIModel, RateDependentPI or PreisachModel
        The hysteresis model: a bank of play operators with ``thresholds`` and ``state0``.
    history : array_like of shape (m,)
        Virtual input extrema (input units), applied in order before the first sample.
    """

    type_name: ClassVar[str] = "initial-memory"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("history", "numbers", doc="virtual input extrema before the record",
              title="Input history u_k", control=Control("u{i}", "input", (-1.25, 1.25))),
        Field("model", "model",
              doc="the hysteresis model ('pi', 'rate', 'preisach' or 'rate-preisach')"),
    )
    model: Model
    history: Float1D

    def __post_init__(self) -> None:
        if not isinstance(self.model, _PLAY_BANK_MODELS):
            raise ParameterError(
                "initial-memory wraps a 'pi', 'rate', 'preisach' or 'rate-preisach' model (a bank "
                f"of play operators), got {type(self.model).__name__}"
            )
        object.__setattr__(self, "history", as_vector(self.history, "history"))

    @property
    def needs_dt(self) -> bool:  # type: ignore[override]
        return self.model.needs_dt

    @property
    def play_state(self) -> Float1D:
        """Play outputs after the virtual history, shape (n,)."""
        from ..operators import play_bank

        m = self.model
        assert isinstance(m, _PLAY_BANK_MODELS)  # __post_init__
        _, z = play_bank(self.history, m.thresholds, m.state0)
        return frozen(z)

    def with_state(self) -> Model:
        """The wrapped model with ``state0`` set to :attr:`play_state`."""
        m = self.model
        assert isinstance(m, _PLAY_BANK_MODELS)  # __post_init__
        return dataclasses.replace(m, state0=self.play_state)

    def as_chain(self) -> Chain:
        """The one-stage chain of :meth:`with_state` (how the C export sees it)."""
        return Chain((self.with_state(),))

    def default_state(self) -> Any:
        return self.with_state().default_state()

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        return self.with_state()._run(u, state, dt)

    def inverse(self) -> Model:
        return self.with_state().inverse()
