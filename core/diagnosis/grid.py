"""Where the play thresholds of a diagnosis go: the baseline's uniform grid.

Used by the structure fit (:mod:`core.diagnosis.structure`) and by the loop shapes
(:mod:`core.diagnosis.shapes`, on the mapped input), so that neither imports the other.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from .._typing import Float1D
from ..exceptions import ParameterError
from ..fitting.thresholds import half_travels
from ..fitting.thresholds import place_thresholds as fit_thresholds

__all__ = ["baseline_thresholds"]


class HasInput(Protocol):
    """What :func:`baseline_thresholds` reads of a recording: its input ``u``."""

    @property
    def u(self) -> Float1D: ...


def baseline_thresholds(
    records: Sequence[HasInput], masks: Sequence[np.ndarray], n: int
) -> Float1D:
    """Uniform thresholds ``r_i = 0.95 · a_max · i / n`` (:func:`core.fitting.place_thresholds`).

    ``a_max`` is the largest half-travel between input reversals inside the training rows
    (:func:`core.fitting.thresholds.half_travels`), or the largest excursion from the first
    sample (plays start at rest there), if larger.
    """
    a_max = 0.0
    for r, m in zip(records, masks, strict=True):
        u = r.u[m] if m.any() else r.u
        if float(np.ptp(u)) > 0:
            a_max = max(a_max, float(half_travels([u]).max()))
        # from the (virgin) initial state the first travel moves plays up to its full length
        a_max = max(a_max, float(np.max(np.abs(r.u - r.u[0]))))
    if a_max <= 0:
        raise ParameterError("the input never moves in the training data; nothing to fit")
    return fit_thresholds([r.u for r in records], n, "uniform", r_max=0.95 * a_max)
