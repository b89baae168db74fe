"""Which way a recording's loops run: the signed loop area.

A piezo actuator's loop runs counter-clockwise in the (u, y) plane (the output lags: it
rises along the lower branch and falls along the upper one), a friction damper's or a
stress-strain material's clockwise (the output leads: it jumps after a reversal, then
saturates). The kinds of :mod:`core.fitting` fit the orientation the data have:
:func:`loop_orientation` measures it once, from the training rows, as the signed area

    A = sum_k (e_k + e_{k+1}) / 2 * (u_{k+1} - u_k)

of the output left after its best straight line in ``u`` (``e = y - a - b u``, which a
straight line cannot change on a closed loop and which removes the line's own contribution
on a record that does not close): ``A > 0`` clockwise, ``A < 0`` counter-clockwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._typing import Float1D

__all__ = ["CLOCKWISE", "COUNTER_CLOCKWISE", "LoopOrientation", "loop_orientation"]

CLOCKWISE = "clockwise"
COUNTER_CLOCKWISE = "counter-clockwise"


@dataclass(frozen=True)
class LoopOrientation:
    """The orientation of a recording's loops.

    Attributes
    ----------
    direction : {"clockwise", "counter-clockwise"}
        Which way the loops run in the (u, y) plane.
    area : float
        The signed loop area (input units x output units; > 0 clockwise), summed over the
        rows it was measured on.
    relative_area : float
        ``|area|`` over ``sum |du| x range(y)``: the loops' mean width as a fraction of the
        output range (0 for a memoryless curve; a few % is a thin but clear loop).
    """

    direction: str
    area: float
    relative_area: float

    @property
    def clockwise(self) -> bool:
        """Whether the output leads (friction, stress-strain)."""
        return self.direction == CLOCKWISE

    @property
    def text(self) -> str:
        """The orientation in words, for the fit report."""
        who = ("the output leads: friction-like or stress-strain loops" if self.clockwise
               else "the output lags: piezo-like loops")
        return (f"loops run {self.direction} in the (input, output) plane ({who}; signed "
                f"loop area {self.relative_area:.1%} of the travel x output range)")


def loop_orientation(us: Sequence[Float1D], ys: Sequence[Float1D],
                     masks: Sequence[np.ndarray] | None = None) -> LoopOrientation:
    """The signed loop area of recordings (the module docstring), on the masked rows.

    Parameters
    ----------
    us, ys : sequence of ndarray of shape (N_i,)
        Inputs and outputs of each recording.
    masks : sequence of bool ndarray of shape (N_i,), optional
        Rows that count (training rows); a step counts when both its ends do. Default: all.

    Returns
    -------
    LoopOrientation
        Counter-clockwise (the play operators' orientation) when the area is exactly 0.
    """
    ms = [np.ones(u.size, bool) for u in us] if masks is None else list(masks)
    sel_u = np.concatenate([u[m] for u, m in zip(us, ms, strict=True)])
    sel_y = np.concatenate([y[m] for y, m in zip(ys, ms, strict=True)])
    if sel_u.size < 3 or np.ptp(sel_u) == 0:
        return LoopOrientation(COUNTER_CLOCKWISE, 0.0, 0.0)
    A = np.column_stack((np.ones(sel_u.size), sel_u))
    coef = np.linalg.lstsq(A, sel_y, rcond=None)[0]
    area = 0.0
    travel = 0.0
    for u, y, m in zip(us, ys, ms, strict=True):
        e = y - coef[0] - coef[1] * u
        both = m[1:] & m[:-1]
        du = np.diff(u)[both]
        area += float(np.sum(0.5 * (e[1:] + e[:-1])[both] * du))
        travel += float(np.sum(np.abs(du)))
    yr = float(np.ptp(sel_y))
    rel = abs(area) / (travel * yr) if travel > 0 and yr > 0 else 0.0
    return LoopOrientation(CLOCKWISE if area > 0 else COUNTER_CLOCKWISE, area, rel)
