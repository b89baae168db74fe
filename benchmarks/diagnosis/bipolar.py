"""Bipolar recordings of the development set: inputs that swing both ways through 0 V and
grow in amplitude, the excitation a structural or friction test uses (issue 30).

The recordings of :func:`benchmarks.diagnosis.families.family_signals` are unipolar
(0-150 V): a strain-driven plant such as the Menegotto-Pinto steel or the pinched
Bouc-Wen-Baber-Noori element then never crosses zero strain and never meets a larger
excursion than the first, where its non-Masing curvature and its pinching show most.
:func:`bipolar_signals` drives the same plants symmetrically around 0 V, within ±150 V.

The plants of :data:`~benchmarks.diagnosis.families.BASES` accept negative inputs as they
are (their laws are written in the input's increments from the virgin state at 0 V), and
:func:`~benchmarks.diagnosis.families.make_base` keeps its gain (a 0 → 150 → 0 V sweep
spans 100 um): on the stress-strain plants a bipolar ±150 V cycle then spans about the same
stroke as the unipolar sweep (that sweep already reverses the stress from +fy to about
-fy); on ``bouc-wen-1`` about twice it (its reversible term is linear in the input). The
noise and the hidden effects are those of :func:`~benchmarks.diagnosis.families.make_family`
(noise a fraction of the 100 um stroke, effects at their ``large`` size).

Case ids (:mod:`benchmarks.diagnosis.sets`): ``dev/family-bipolar/<base>/<effect>/large/<seed>``,
``dev/family-bipolar/<base>/null/<seed>`` and single-recording nulls
``dev/family-bipolar-single/<base>/<recording>/<seed>``.
"""

from __future__ import annotations

import numpy as np

from benchmarks.diagnosis.families import U_MAX, make_family
from benchmarks.diagnosis.generator import Scenario

__all__ = ["BIPOLAR_RECORDINGS", "SIGNAL_SEED", "bipolar_signals", "make_bipolar",
           "random_reversals"]

#: Seed of the random-reversal recording (from the development block 0-1999; fixed, so
#: every case sees the same inputs).
SIGNAL_SEED = 1212
#: Names of the recordings of :func:`bipolar_signals`, in order.
BIPOLAR_RECORDINGS = ("growing", "fast", "decaying", "reversals", "staircase")


def _sine_blocks(blocks: list[tuple[float, float, int]], fs: float) -> np.ndarray:
    """Sines ``amp sin(2 pi f t)`` of whole cycles, one after the other: ``blocks`` is a list
    of ``(amplitude V, frequency Hz, cycles)``; every block starts and ends at 0 V rising,
    so the input is continuous where the amplitude or the frequency changes."""
    parts = []
    for amp, f, cyc in blocks:
        tt = np.arange(0, int(round(cyc * fs / f))) / fs
        parts.append(amp * np.sin(2 * np.pi * f * tt))
    return np.concatenate(parts)


def random_reversals(seed: int = SIGNAL_SEED, legs: int = 14, rate_v_s: float = 300.0,
                     holds: int = 4, hold_s: float = 1.2, fs: float = 1000.0) -> np.ndarray:
    """A random-reversal input (V), shape (n,): from 0 V, ``legs`` straight legs at
    ``rate_v_s`` to targets of alternating sign and random size (30-150 V), ``holds`` of
    them (chosen at random, not the first) followed by a hold of ``hold_s`` s at their
    target, and a last leg back to 0 V; sampled at ``fs`` Hz."""
    rng = np.random.default_rng(seed)
    sign = 1.0 if rng.uniform() < 0.5 else -1.0
    targets = [sign * (-1.0) ** i * rng.uniform(30.0, U_MAX) for i in range(legs)] + [0.0]
    held = set(rng.choice(np.arange(1, legs), size=holds, replace=False).tolist())
    parts, prev = [np.zeros(1)], 0.0
    for i, tg in enumerate(targets):
        m = max(2, int(round(abs(tg - prev) / rate_v_s * fs)))
        parts.append(np.linspace(prev, tg, m + 1)[1:])
        if i in held:
            parts.append(np.full(int(round(hold_s * fs)), tg))
        prev = tg
    return np.concatenate(parts)


def bipolar_signals() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The five bipolar recordings ``(name, t, u)`` (t in s, u in V), about 71 k samples.

    ``growing``: a sine at 2.5 Hz whose amplitude grows in steps, 30, 60, 90, 120, 150 V,
    two cycles each, 2.5 kHz, 4 s;
    ``fast``: 8 cycles at 40 Hz of ±150 V, then 24 at 120 Hz of ±100 V, 10 kHz, 0.4 s;
    ``decaying``: a 0.6 Hz sine around 0 V, amplitude 150 V e^(-t / 4 s), 2 kHz, 9 s;
    ``reversals``: :func:`random_reversals` (14 legs at 300 V/s, four holds of 1.2 s),
    1 kHz;
    ``staircase``: 0, 40, 80, 120, 150, 60, -30, -120, -150, -75, 0 V, steps ramped over
    5 ms, 2 s holds, 1 kHz, 22 s.
    """
    out = []
    fs = 2500.0
    u = _sine_blocks([(a, 2.5, 2) for a in (30.0, 60.0, 90.0, 120.0, 150.0)], fs)
    out.append(("growing", np.arange(u.size) / fs, u))
    fs = 10000.0
    u = _sine_blocks([(U_MAX, 40.0, 8), (100.0, 120.0, 24)], fs)
    out.append(("fast", np.arange(u.size) / fs, u))
    fs = 2000.0
    t = np.arange(0, 9.0, 1 / fs)
    out.append(("decaying", t, U_MAX * np.exp(-t / 4.0) * np.sin(2 * np.pi * 0.6 * t)))
    fs = 1000.0
    u = random_reversals(fs=fs)
    out.append(("reversals", np.arange(u.size) / fs, u))
    parts, prev = [], 0.0
    for lv in (0.0, 40.0, 80.0, 120.0, 150.0, 60.0, -30.0, -120.0, -150.0, -75.0, 0.0):
        parts.append(np.linspace(prev, lv, 6)[1:])
        parts.append(np.full(int(2.0 * fs) - 5, lv))
        prev = lv
    u = np.concatenate(parts)
    out.append(("staircase", np.arange(u.size) / fs, u))
    return out


def make_bipolar(base: str, effect: str | None = None, size: str = "large",
                 noise: float = 0.002, seed: int = 0) -> Scenario:
    """:func:`~benchmarks.diagnosis.families.make_family` on the recordings of
    :func:`bipolar_signals` (same bases, effects, sizes, noise and truth ``extras``, plus
    ``extras["excitation"] = "bipolar"``)."""
    sc = make_family(base, effect, size, noise=noise, seed=seed, signals=bipolar_signals())
    sc.extras["excitation"] = "bipolar"
    return sc
