"""Does the loop change from cycle to cycle under a repeated input (degradation, hardening)?

A rate-independent memory base (PI, Preisach, stop operators, Maxwell-slip elements)
repeats its output exactly once the input has gone through the same cycle (the same
extrema, the same history) once: every later cycle of a run of identical input cycles gives
the same loop. A loop that keeps shrinking or growing under the same input (a structural
element that softens and loses strength with the energy it has dissipated, a material that
hardens cyclically) is outside every such base. A drift, creep or an offset shift moves the
loop's mean; this check reads its shape only.

:func:`cycle_change` takes, in each recording, the longest run of identical input cycles
(:func:`core.fitting.cycles.repeating_run`, the rule of the diagnosis's cycle-to-cycle
test), drops its first cycle (the memory may still be set there), and
per cycle measures the loop's size as the least-squares scale of its output, mean removed,
against the mean such loop over the run (its peak-to-peak output moves with it) and the
enclosed area (the integral of the output over the input, around the cycle). The change of
the size per cycle is a straight-line fit over the cycles; its standard error is the larger
of the scatter of the cycles about the line (the cycles' noise is independent) and what the
white-noise floor alone gives. The loop changes when the fit's ``|z|`` is at least
:data:`CHANGE_Z` and the change over the run is at least :data:`MIN_CHANGE` of the loop's
size.

Measured: the benchmark's pinched element with degradation (``delta_nu = delta_eta =
0.0005``, four family recordings at 0.2 % noise; the fast recording's ten 20 Hz cycles)
shrinks by 0.31 % per cycle (z = -16); without degradation, and on every development family
null (Menegotto-Pinto, pinched, Maxwell-slip, Bouc-Wen, Preisach, Duhem) and a PI null,
``|z| <= 1.6``. The shipped piezo recording (five identical 1 Hz cycles after the first):
-0.008 % per cycle, z = -2.0, nothing said; the friction damper recordings repeat at most
three identical cycles and are not tested.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..recordings import Recording
from .cycles import repeating_run

__all__ = ["CHANGE_Z", "CYCLE_TOL", "MIN_CHANGE", "MIN_RUN", "START_TOL", "CycleChange",
           "cycle_change", "cycle_change_of"]

#: One input cycle repeats the one before when their RMS difference is below this share of
#: the input's range (the diagnosis's cycle-to-cycle test uses the same).
CYCLE_TOL = 0.02
#: A cycle follows the one before when it starts one period later within this share of the
#: period.
START_TOL = 0.05
#: Fewest cycles compared (after the run's first).
MIN_RUN = 4
#: The loop changes when the per-cycle change's z is at least this ...
CHANGE_Z = 5.0
#: ... and the change over the compared cycles at least this share of the loop's size.
MIN_CHANGE = 0.005


@dataclass(frozen=True)
class CycleChange:
    """The loop's change from cycle to cycle on one recording (:func:`cycle_change_of`).

    Attributes
    ----------
    recording : str
        Recording name.
    cycles : int
        Cycles compared (the run's first left out).
    t_span : tuple of float
        Start of the first and end of the last compared cycle (s, or sample index).
    per_cycle_pct : float
        Change of the loop's size (its peak-to-peak output) per cycle, % of its mean size
        (< 0: shrinking).
    area_per_cycle_pct : float
        Change of the enclosed area per cycle, % of its mean (NaN for a loop of no area).
    mean_per_cycle : float
        Shift of the output's mean per cycle (output units; a drift or creep moves it).
    z : float
        ``per_cycle_pct`` over its standard error.
    changes : bool
        ``|z| >= CHANGE_Z`` and the change over the cycles is at least :data:`MIN_CHANGE`.
    timed : bool
        The recording has a time axis (``t_span`` in s); else ``t_span`` counts samples.
    """

    recording: str
    cycles: int
    t_span: tuple[float, float]
    per_cycle_pct: float
    area_per_cycle_pct: float
    mean_per_cycle: float
    z: float
    changes: bool
    timed: bool = True

    def text(self) -> str:
        """The finding in words (``""`` when the loop repeats)."""
        if not self.changes:
            return ""
        how = ("softening / degrading" if self.per_cycle_pct < 0 else "hardening")
        area = ("" if not np.isfinite(self.area_per_cycle_pct) else
                f", its enclosed area by {self.area_per_cycle_pct:+.2f} % per cycle")
        return (f"the loop changes from cycle to cycle under a repeated input ({how}): on "
                f"{self.recording}, over {self.cycles} identical input cycles "
                + (f"from t = {self.t_span[0]:.4g} to {self.t_span[1]:.4g} s" if self.timed else
                   f"from sample {self.t_span[0]:.0f} to {self.t_span[1]:.0f}")
                + ", its peak-to-peak output "
                f"changes by {self.per_cycle_pct:+.2f} % per cycle (z = {self.z:.1f}){area}; "
                "a rate-independent memory base repeats a repeated cycle exactly (a drift "
                "or creep would shift the loop's mean, not its size); fit the cycles after the "
                "loop has settled, or a model whose loop changes with the energy dissipated")


def _fit_slope(k: np.ndarray, v: np.ndarray, floor_se: float) -> tuple[float, float]:
    """Slope of ``v`` over ``k`` and its standard error (at least ``floor_se``)."""
    kc = k - k.mean()
    sxx = float(kc @ kc)
    slope = float(kc @ (v - v.mean())) / sxx
    res = v - v.mean() - slope * kc
    se = float(np.sqrt(res @ res / max(k.size - 2, 1) / sxx))
    return slope, max(se, floor_se)


def cycle_change_of(rec: Recording, noise: float) -> CycleChange | None:
    """The loop's change from cycle to cycle on ``rec`` (module docstring).

    Parameters
    ----------
    rec : Recording
        Input ``u`` and output ``y``, shape ``(N,)`` each.
    noise : float
        White-noise floor of the output (output units, RMS).

    Returns
    -------
    CycleChange or None
        ``None`` when the input repeats fewer than ``MIN_RUN + 1`` identical cycles.
    """
    run = repeating_run(rec.u, CYCLE_TOL, START_TOL)
    if len(run) < MIN_RUN + 1:
        return None
    run = run[1:]
    y = np.asarray(rec.y, dtype=np.float64)
    u = np.asarray(rec.u, dtype=np.float64)
    ys = np.stack([y[a:b] for a, b in run])
    us = np.stack([u[a:b] for a, b in run])
    means = ys.mean(axis=1)
    shapes = ys - means[:, None]
    ref = shapes.mean(axis=0)
    rr = float(ref @ ref)
    if not rr > 0:
        return None
    size = shapes @ ref / rr  # 1 on average
    # the enclosed area: the output integrated over the input around the closed cycle
    du = np.diff(np.concatenate([us, us[:, :1]], axis=1), axis=1)
    yc = 0.5 * (ys + np.roll(ys, -1, axis=1))
    area = np.abs(np.sum(yc * du, axis=1))
    k = np.arange(len(run), dtype=np.float64)
    n = float(len(run))
    floor_k = float(np.sqrt(12.0 / (n * (n * n - 1.0))))  # SE factor of a slope over k
    slope, se = _fit_slope(k, size, noise / np.sqrt(rr) * floor_k)
    aslope, _ = _fit_slope(k, area, 0.0)
    mslope, _ = _fit_slope(k, means, 0.0)
    amean = float(area.mean())
    z = slope / se if se > 0 else 0.0
    changes = abs(z) >= CHANGE_Z and abs(slope) * (n - 1.0) >= MIN_CHANGE
    area_pct = 100.0 * aslope / amean if amean > 1e-9 * float(np.ptp(ys)) * float(
        np.ptp(us)) else float("nan")
    t = np.asarray(rec.t)
    return CycleChange(rec.name, len(run), (float(t[run[0][0]]), float(t[run[-1][1] - 1])),
                       100.0 * slope, area_pct, mslope, z, bool(changes), bool(rec.has_time))


def cycle_change(records: Sequence[Recording], noise: float) -> CycleChange | None:
    """The recording whose loop changes most clearly from cycle to cycle (the largest
    ``|z|`` among those that change), else the one with the most compared cycles, or
    ``None`` when no recording repeats enough identical cycles.

    Parameters
    ----------
    records : sequence of Recording
    noise : float
        White-noise floor of the output (output units, RMS).
    """
    found = [c for c in (cycle_change_of(r, noise) for r in records) if c is not None]
    if not found:
        return None
    changing = [c for c in found if c.changes]
    if changing:
        return max(changing, key=lambda c: abs(c.z))
    return max(found, key=lambda c: c.cycles)
