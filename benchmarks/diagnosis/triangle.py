"""A growing triangle at one input rate, alone, in the development set (issue 30): the
cyclic protocol of a structural or friction test, whose amplitude steps up every two
cycles while the input keeps one rate (V/s).

Every rising branch from a negative peak is visited twice: in the second cycle at an
amplitude it starts from the same input history as in the first (same direction, same
unwiped extrema) but goes on to the next, larger amplitude, so it is longer in samples.
Over their common stretch (from the reversal up to the first branch's end) the two are at
the same rate and the same history, the pairs :func:`core.diagnosis.periodic.same_history`
compares to tell a slow change with time (a drift) from the model's bias in a single
recording, which is too short (12 s) and repeats its cycle too few times for the other
tests of a drift.

Case ids (:mod:`benchmarks.diagnosis.sets`, class ``growing-triangle non-PI base``):
``dev/family-triangle/<base>/null/<seed>`` and ``dev/family-triangle/<base>/drift/large/<seed>``
on the bases :data:`TRIANGLE_BASES` (three that keep Masing's rule within the noise on this
input, and the non-Masing steel, whose first visit of a history is compared with nothing).
"""

from __future__ import annotations

import numpy as np

from benchmarks.diagnosis.families import make_family
from benchmarks.diagnosis.generator import Scenario

__all__ = ["TRIANGLE_AMPLITUDES", "TRIANGLE_BASES", "TRIANGLE_RATE", "growing_triangle",
           "make_triangle"]

#: Peak input of each step (V), two cycles each.
TRIANGLE_AMPLITUDES = (37.5, 75.0, 112.5, 150.0)
#: The one input rate (V/s).
TRIANGLE_RATE = 250.0
#: Bases of the development cases on this recording.
TRIANGLE_BASES = ("bouc-wen-1", "preisach", "maxwell-slip", "menegotto-pinto")


def growing_triangle(amplitudes: tuple[float, ...] = TRIANGLE_AMPLITUDES, cycles: int = 2,
                     rate_v_s: float = TRIANGLE_RATE, fs: float = 1000.0
                     ) -> tuple[np.ndarray, np.ndarray]:
    """``(t, u)`` (s, V), shape (n,) each: from 0 V, ``cycles`` triangle cycles
    ``+a, -a`` at each amplitude ``a`` of ``amplitudes`` in turn, then back to 0 V, every
    leg straight at ``rate_v_s`` and sampled at ``fs`` Hz (12 s, 12 001 samples with the
    defaults)."""
    targets = [s * a for a in amplitudes for _ in range(cycles) for s in (1.0, -1.0)] + [0.0]
    parts, prev = [np.zeros(1)], 0.0
    for tg in targets:
        m = max(2, int(round(abs(tg - prev) / rate_v_s * fs)))
        parts.append(np.linspace(prev, tg, m + 1)[1:])
        prev = tg
    u = np.concatenate(parts)
    return np.arange(u.size) / fs, u


def make_triangle(base: str, effect: str | None = None, size: str = "large",
                  noise: float = 0.002, seed: int = 0) -> Scenario:
    """:func:`~benchmarks.diagnosis.families.make_family` on the one recording
    ``"triangle"`` of :func:`growing_triangle` (same bases, effects, sizes, noise and truth
    ``extras``, plus ``extras["excitation"] = "growing triangle"``; ``concealment_pct``
    over this recording: the largest change the hidden effect makes to the base's output,
    in % of the stroke)."""
    t, u = growing_triangle()
    sc = make_family(base, effect, size, noise=noise, seed=seed, signals=[("triangle", t, u)],
                     concealed_over=("triangle",))
    sc.extras["excitation"] = "growing triangle"
    return sc
