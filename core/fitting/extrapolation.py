"""Whether the held-out rows ask a fit to extrapolate: inputs its training rows never reach.

A held-out error only says how well a model predicts when the held-out rows lie where the
training rows taught it something. The default split of ``hyst fit`` holds out the last
20 % of every recording; on a recording that ends on its way to a peak (a B-H loop that
starts at its peak field, whose rows before the input first reached both ends are left
out of the weight fit) the held-out rows reach inputs the fitted rows never visit, and the
held-out error then measures extrapolation (the shipped amorphous-alloy loop: held out
674 to 800 A/m, fitted on -800 to 674 A/m, 555 % of range). :func:`extrapolation` finds
such rows; :meth:`Extrapolation.text` says it in words, with how to fix the split.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._typing import Float1D

__all__ = ["EXTRAPOLATION_MARGIN", "Beyond", "Extrapolation", "extrapolation"]

#: Held-out inputs beyond the fitted rows' input range by more than this share of that
#: range count as extrapolation (a clear margin: a play operator's threshold spacing of a
#: 25-operator model is ~4 % of the range).
EXTRAPOLATION_MARGIN = 0.05


@dataclass(frozen=True)
class Beyond:
    """One recording's held-out rows outside the fitted rows' input range.

    Attributes
    ----------
    recording : str
        Its name.
    inputs : tuple of float
        The held-out inputs beyond the range: lowest and highest of them (input units).
    rows : tuple of float
        First and last of those rows: times (s), or sample numbers (from 0) when ``timed``
        is false.
    share : float
        The share of the recording's held-out rows beyond the range.
    timed : bool
        Whether the recording has a time axis.
    """

    recording: str
    inputs: tuple[float, float]
    rows: tuple[float, float]
    share: float
    timed: bool


@dataclass(frozen=True)
class Extrapolation:
    """Held-out rows whose inputs leave the fitted rows' input range.

    Attributes
    ----------
    fitted : tuple of float
        Lowest and highest input of the rows the model was fitted on (input units).
    beyond : tuple of Beyond
        The recordings whose held-out rows leave that range by :data:`EXTRAPOLATION_MARGIN`.
    excluded : bool
        Whether training rows before the wipe-out time were left out of the fit (the
        initial-memory rule), which narrowed the fitted range.
    """

    fitted: tuple[float, float]
    beyond: tuple[Beyond, ...]
    excluded: bool = False

    def text(self, units: dict[str, str] | None = None) -> str:
        """The warning in words (``units``: the recording's ``"input"`` unit)."""
        ui = f" {units['input']}" if units and units.get("input") else ""
        parts = []
        for b in self.beyond:
            where = (f"t = {b.rows[0]:.4g} to {b.rows[1]:.4g} s" if b.timed else
                     f"samples {b.rows[0]:.0f} to {b.rows[1]:.0f}")
            parts.append(f"on {b.recording}, {100 * b.share:.0f} % of them reach inputs "
                         f"{b.inputs[0]:.4g} to {b.inputs[1]:.4g}{ui} ({where})")
        why = (" (the training rows before the input first reached both ends of its range "
               "were left out of the fit because the state they start from is unknown; "
               "--initial-memory keep fits them from the relaxed state)"
               if self.excluded else "")
        timed = all(b.timed for b in self.beyond)
        unit = "seconds" if timed else "sample numbers, as these recordings have no time axis"
        return (f"the held-out rows ask the model to extrapolate: {'; '.join(parts)}, beyond "
                f"the inputs of the rows it was fitted on ({self.fitted[0]:.4g} to "
                f"{self.fitted[1]:.4g}{ui}){why}. There the held-out error measures "
                "extrapolation, not how well the model describes the loops. Hold out rows "
                "whose inputs the training rows cover: choose --train and --test windows "
                f"(in {unit}), e.g. a middle stretch of each recording, or hold out whole "
                "recordings of a family and fit the others")


def extrapolation(
    us: Sequence[Float1D], ts: Sequence[Float1D], fitted: Sequence[np.ndarray],
    held_out: Sequence[np.ndarray], names: Sequence[str] = (), timed: Sequence[bool] = (),
    *, excluded: bool = False,
) -> Extrapolation | None:
    """Held-out rows whose inputs leave the fitted rows' input range by a clear margin.

    Parameters
    ----------
    us, ts : sequence of ndarray of shape (N_i,)
        Input (input units) and time (s, or sample numbers) of each recording.
    fitted, held_out : sequence of bool ndarray of shape (N_i,)
        The rows the model was fitted on and the held-out rows.
    names : sequence of str, optional
        Recording names.
    timed : sequence of bool, optional
        Whether each recording has a time axis (default: all do).
    excluded : bool
        Whether rows before the wipe-out time were left out of ``fitted``.

    Returns
    -------
    Extrapolation or None
        ``None`` when no recording's held-out rows leave the range by more than
        :data:`EXTRAPOLATION_MARGIN` of it (or there are no fitted rows).
    """
    seen = [u[m] for u, m in zip(us, fitted, strict=True) if m.any()]
    if not seen:
        return None
    lo = min(float(x.min()) for x in seen)
    hi = max(float(x.max()) for x in seen)
    margin = EXTRAPOLATION_MARGIN * max(hi - lo, 1e-300)
    out = []
    for k, (u, t, m) in enumerate(zip(us, ts, held_out, strict=True)):
        if not m.any():
            continue
        rows = np.flatnonzero(m)
        far = (u[rows] < lo - margin) | (u[rows] > hi + margin)
        if not far.any():
            continue
        out_rows = np.flatnonzero(m & ((u < lo) | (u > hi)))
        v = u[out_rows]
        out.append(Beyond(names[k] if k < len(names) else f"recording {k}",
                          (float(v.min()), float(v.max())),
                          (float(t[out_rows[0]]), float(t[out_rows[-1]])),
                          float(out_rows.size / rows.size),
                          bool(timed[k]) if k < len(timed) else True))
    if not out:
        return None
    return Extrapolation((lo, hi), tuple(out), excluded)
