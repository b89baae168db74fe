"""Masing's rule: is the branch after a reversal the first loading curve doubled?

Every rate-independent base of the project built from play or stop operators (the PI, its
stop-operator form, Maxwell-slip elements) obeys Masing's rule: after a reversal the output
moves along the first loading curve from rest scaled by two in both axes,
``F1(d) = 2 F0(d / 2)``, where ``F0`` is the output's change along the first loading (from
the first sample) over an input travel ``d`` and ``F1`` the change along the branch after
the first reversal, signed in the branch's direction (valid for ``d`` up to twice the first
loading's travel). A plant whose transition after a reversal depends on how far the input
went before (steel with a Menegotto-Pinto law: the transition rounds off after a plastic
excursion, sharp on the first loading) or whose loop pinches (the branch flattens near zero
force and stiffens again) departs from it, and no weighting of those operators follows it.

:func:`masing` measures the departure on each recording from the first loading to the first
reversal: the RMS of ``F1(d) - 2 F0(d / 2)`` over the branch after that reversal, in % of
that branch's rise, and against the noise it carries (``sqrt(5)`` times the noise floor:
one sample of ``F1``, two of ``F0`` doubled). It calls the recordings non-Masing when the
median departure over the recordings with a first loading from rest and a reversal is at
least :data:`MASING_SHARE` of the rise and :data:`MASING_RATIO` times that noise.

A recording that did not start from rest in the demagnetized state (its first loading not
a virgin curve) departs as well. :func:`masing_check` therefore compares only a first
loading that is not a piece of a later branch: the next branch in the same direction must
cover at least :data:`STEADY_SPAN` of the input range with the first loading, and there
differ from it, mean removed, by at least :data:`STEADY_SHARE` of its output range. A
recording that starts on its steady loop repeats the later branch there (the development
Preisach family, whose relays all start down: 0.2 %); the shipped piezo, friction damper
and B-H recordings have no such pair of branches and are not tested; the development
families that start from rest differ by 2.5-27 %. The words still name a start that was not
from rest as the other possible cause.

Development families (``benchmarks/diagnosis/families.py``: slow, fast and decaying
recordings from rest, 0.2 % noise): Menegotto-Pinto steel 10.6-12.4 % (median 10.9 %, 24
times the noise), the pinched Bouc-Wen-Baber-Noori element 8.1-11.4 % (median 8.1 %);
Maxwell-slip 0.4-0.6 %, Bouc-Wen 1.6-3.1 % (median 2.0 %), Preisach 1.6 % (decaying only),
Duhem 2.0-4.5 % (median 2.1 %), a PI plant 0.05 %; the sharper Bouc-Wen kinds up to 5 %
(n = 2: a Bouc-Wen branch depends on the state at its reversal, so it is not Masing either,
but its own base follows it, and the diagnosis never says this of a base that fits).

A branch is called pinched when its slope, read over tenths of its travel, falls to at most
:data:`PINCH_DIP` of its largest value and then rises again to at least twice that low
before the branch ends (an S-shaped branch; a Masing or Menegotto-Pinto branch only
flattens).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..recordings import Recording
from .thresholds import reversal_indices

__all__ = ["MASING_RATIO", "MASING_SHARE", "PINCH_DIP", "REVERSAL_SHARE", "STEADY_SHARE",
           "STEADY_SPAN", "Masing",
           "MasingCheck", "masing", "masing_check"]

#: A reversal counts when the input turns back by at least this share of its range.
REVERSAL_SHARE = 0.1
#: The recordings are non-Masing when the median departure is at least this share of the
#: branch's rise ...
MASING_SHARE = 0.07
#: ... and at least this many times the noise it carries.
MASING_RATIO = 5.0
#: A branch is pinched when its slope dips to at most this share of its largest value and
#: rises again to at least twice the dip.
PINCH_DIP = 0.35
#: The first loading and the next branch in its direction must overlap over this share of
#: the input range ...
STEADY_SPAN = 0.3
#: ... and differ there by this share of the later branch's output range for the first
#: loading to count as one from rest.
STEADY_SHARE = 0.01
#: Fewest samples on the compared branch.
MIN_SAMPLES = 20


@dataclass(frozen=True)
class MasingCheck:
    """Masing's rule on one recording (:func:`masing_check`).

    Attributes
    ----------
    recording : str
        Recording name.
    t_reversal : float
        Time of the first reversal (s, or sample index without a time axis).
    first_travel : float
        Input travel of the first loading (input units).
    window : float
        Input travel after the reversal over which the branch is compared (input units).
    rise : float
        The branch's output change over ``window`` (output units, positive).
    departure : float
        RMS of ``F1(d) - 2 F0(d / 2)`` over the window (output units).
    departure_pct : float
        ``departure`` in % of ``rise``.
    ratio : float
        ``departure`` over the noise it carries (``sqrt(5)`` noise floors).
    pinched : bool
        The branch is S-shaped (module docstring).
    timed : bool
        The recording has a time axis (``t_reversal`` in s); else it counts samples.
    """

    recording: str
    t_reversal: float
    first_travel: float
    window: float
    rise: float
    departure: float
    departure_pct: float
    ratio: float
    pinched: bool
    timed: bool = True


def _slope_dips(x: np.ndarray, f: np.ndarray) -> bool:
    """Whether the branch ``f(x)`` (``x`` increasing from 0) is S-shaped: its slope over
    tenths of the travel dips to :data:`PINCH_DIP` of its largest and rises again."""
    edges = np.linspace(0.0, float(x[-1]), 11)
    k = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, 9)
    if any(not np.any(k == j) for j in range(10)):
        return False
    xm = np.array([x[k == j].mean() for j in range(10)])
    fm = np.array([f[k == j].mean() for j in range(10)])
    s = np.diff(fm) / np.diff(xm)
    top = float(s.max())
    if not top > 0:
        return False
    j = int(np.argmin(s))
    return bool(0 < j < s.size - 1 and s[j] <= PINCH_DIP * top
            and float(s[j + 1:].max()) >= 2.0 * max(float(s[j]), 0.0) + 0.1 * top)


def _from_rest(u: np.ndarray, y: np.ndarray, b: list[int]) -> bool:
    """Whether the first loading (``b[0]`` to ``b[1]``) is not a piece of the next branch in
    its direction (``b[2]`` to ``b[3]``): they overlap over :data:`STEADY_SPAN` of the input
    range and differ there, mean removed, by at least :data:`STEADY_SHARE` of that branch's
    output range (module docstring)."""
    if len(b) < 4:
        return False
    ua, ya = u[b[0]:b[1] + 1], y[b[0]:b[1] + 1]
    uc, yc = u[b[2]:b[3] + 1], y[b[2]:b[3] + 1]
    lo, hi = max(ua.min(), uc.min()), min(ua.max(), uc.max())
    if hi - lo < STEADY_SPAN * float(np.ptp(u)):
        return False
    grid = np.linspace(lo, hi, 200)
    oa, oc = np.argsort(ua, kind="stable"), np.argsort(uc, kind="stable")
    d = np.interp(grid, ua[oa], ya[oa]) - np.interp(grid, uc[oc], yc[oc])
    d = d - d.mean()
    return bool(np.sqrt(np.mean(d * d)) >= STEADY_SHARE * float(np.ptp(yc)))


def masing_check(rec: Recording, noise: float) -> MasingCheck | None:
    """Masing's rule on recording ``rec`` (module docstring).

    Parameters
    ----------
    rec : Recording
        Input ``u`` and output ``y``, shape ``(N,)`` each.
    noise : float
        White-noise floor of the output (output units, RMS).

    Returns
    -------
    MasingCheck or None
        ``None`` without a first loading from rest (:func:`_from_rest`) and a reversal
        after it, or with fewer than :data:`MIN_SAMPLES` samples on the compared branch.
    """
    u = np.asarray(rec.u, dtype=np.float64)
    y = np.asarray(rec.y, dtype=np.float64)
    span = float(np.ptp(u)) if u.size else 0.0
    if not span > 0:
        return None
    rv = reversal_indices(u, REVERSAL_SHARE * span)
    b = [*rv.tolist(), u.size - 1]
    if len(b) < 4 or b[0] != 0 or not _from_rest(u, y, b):
        return None
    a0, a1, a2 = b[0], b[1], b[2]
    s = float(np.sign(u[a1] - u[a0]))
    x0 = np.maximum.accumulate(s * (u[a0:a1 + 1] - u[a0]))
    f0 = s * (y[a0:a1 + 1] - y[a0])
    x1 = np.maximum.accumulate(-s * (u[a1:a2 + 1] - u[a1]))
    f1 = -s * (y[a1:a2 + 1] - y[a1])
    window = min(float(x1[-1]), 2.0 * float(x0[-1]))
    m = (x1 > 0) & (x1 <= window)
    if m.sum() < MIN_SAMPLES:
        return None
    doubled = 2.0 * np.interp(x1[m] / 2.0, x0, f0)
    d = f1[m] - doubled
    dep = float(np.sqrt(np.mean(d * d)))
    rise = float(abs(f1[m][-1]))
    if not rise > 0:
        return None
    carried = float(np.sqrt(5.0)) * noise
    t = float(rec.t[a1])
    return MasingCheck(rec.name, t, float(x0[-1]), window, rise, dep, 100.0 * dep / rise,
                       dep / carried if carried > 0 else float("inf"),
                       _slope_dips(x1[m], f1[m]), bool(rec.has_time))


@dataclass(frozen=True)
class Masing:
    """Masing's rule over recordings (:func:`masing`).

    Attributes
    ----------
    checks : tuple of MasingCheck
        One per recording with a first loading and a reversal.
    departure_pct : float
        Median of their departures (% of the branch's rise; NaN without checks).
    ratio : float
        Median of their departures over the noise they carry (NaN without checks).
    non_masing : bool
        The median departure is at least :data:`MASING_SHARE` of the rise and
        :data:`MASING_RATIO` times the noise.
    pinched : bool
        The non-Masing branches are S-shaped in most recordings.
    """

    checks: tuple[MasingCheck, ...]
    departure_pct: float
    ratio: float
    non_masing: bool
    pinched: bool

    @property
    def departs(self) -> bool:
        """The median departure is at least :data:`MASING_RATIO` times the noise it carries,
        however small a share of the rise: a memory that does not follow Masing's rule
        (a Bouc-Wen element's too, module docstring), though a play or stop base may still
        fit its loops closely."""
        return bool(self.ratio >= MASING_RATIO)

    def text(self, units: dict[str, str] | None = None) -> str:
        """The finding in words (``""`` when the rule holds or was not tested; ``units``: the
        recordings' ``"input"`` and ``"output"`` units)."""
        if not self.non_masing:
            return ""
        ui = f" {units['input']}" if units and units.get("input") else " input units"
        worst = max(self.checks, key=lambda c: c.departure_pct)
        where = "; ".join(f"{c.recording} {c.departure_pct:.1f} %" for c in self.checks)
        shape = ("the loop is pinched: after a reversal the branch flattens, then stiffens "
                 "again before the next turn (an S-shaped branch, as in a pinched or "
                 "degrading structural element)" if self.pinched else
                 "the transition after a reversal changes with the size of the previous "
                 "excursion (as in steel with a Menegotto-Pinto law, sharp on the first "
                 "loading and rounded after a plastic excursion)")
        return (f"non-Masing: the branch after the first reversal is not the first loading "
                f"curve doubled (Masing's rule, which every play- or stop-operator base "
                f"follows); it departs from it by {self.departure_pct:.1f} % of its rise "
                f"(median over {len(self.checks)} recordings, {self.ratio:.0f} times the "
                f"noise; {where}; most on {worst.recording} after the reversal at "
                + (f"t = {worst.t_reversal:.4g} s" if worst.timed else
                   f"sample {worst.t_reversal:.0f}")
                + f", over {worst.window:.4g}{ui} of input travel): "
                f"{shape}, or the recordings did not start from rest in a demagnetized "
                "state. No play- or stop-operator base can follow it: the material's own law "
                "(a non-Masing steel or pinched element model) would, or the fit can be kept "
                "to loops of one size")


def masing(records: Sequence[Recording], noise: float) -> Masing:
    """Masing's rule on each recording and over them (module docstring).

    Parameters
    ----------
    records : sequence of Recording
    noise : float
        White-noise floor of the output (output units, RMS).
    """
    checks = tuple(c for c in (masing_check(r, noise) for r in records) if c is not None)
    if not checks:
        return Masing((), float("nan"), float("nan"), False, False)
    pct = float(np.median([c.departure_pct for c in checks]))
    ratio = float(np.median([c.ratio for c in checks]))
    non = pct >= 100.0 * MASING_SHARE and ratio >= MASING_RATIO
    pinched = non and 2 * sum(c.pinched for c in checks) > len(checks)
    return Masing(checks, pct, ratio, non, pinched)
