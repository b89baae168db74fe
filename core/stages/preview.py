"""The real-time form of a compensator that holds an advance: :func:`causal_form`."""

from __future__ import annotations

from dataclasses import dataclass

from ..base import Chain, Model
from .delay import Advance
from .drift import Drift


@dataclass(frozen=True)
class CausalForm:
    """A compensator that runs sample by sample, fed the desired trajectory ahead of time.

    Attributes
    ----------
    model : Model
        The compensator with every :class:`Advance` replaced by a causal :class:`Delay` and
        every :class:`Drift` behind it started ``preview`` samples early.
    preview : int
        Samples of preview: at step ``k`` feed the desired sample ``k + preview``; the output
        is the drive for sample ``k`` (the first ``preview`` outputs are warm-up).
    """

    model: Model
    preview: int


def causal_form(model: Model, dt: float | None) -> CausalForm:
    """The real-time form of a compensator that may hold advances (inverses of delays).

    Parameters
    ----------
    model : Model
        Typically ``forward.inverse()``.
    dt : float or None
        Sample spacing in seconds (needed when the model holds an advance).

    Returns
    -------
    CausalForm
        ``model`` unchanged with ``preview = 0`` when it has no advance.
    """
    stages = list(model.stages) if isinstance(model, Chain) else [model]
    if not any(isinstance(s, Advance) for s in stages):
        return CausalForm(model, 0)
    assert dt is not None
    out: list[Model] = []
    ahead = 0  # preview consumed by the advances seen so far (samples)
    for s in stages:
        if isinstance(s, Advance):
            ahead += s.preview_samples(dt)
            out.append(s.causal(dt))
        elif isinstance(s, Drift) and ahead:
            out.append(Drift(s.coefficients, s.span_s, s.start_s - ahead * dt))
        else:
            out.append(s)
    return CausalForm(Chain(tuple(out)) if len(out) > 1 else out[0], ahead)
