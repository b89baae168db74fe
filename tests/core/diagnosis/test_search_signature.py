"""A candidate judged where it lives (core.diagnosis.search._on_its_signature) on rows
compared with an earlier row of the same input history (a drift from cycle to cycle of a
repeated input) is marked ``differenced``: the white noise enters such a change twice, so
the excess its 20 % share is counted in subtracts 2 noise², not noise²
(:func:`~core.diagnosis.acceptance.floor_mse`, :func:`~core.diagnosis.judge.excess_of`)."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis.acceptance import floor_mse
from core.diagnosis.candidates import build_candidate
from core.diagnosis.context import FitContext
from core.diagnosis.crossfitting import screen_gain
from core.diagnosis.data import split_masks
from core.diagnosis.grid import baseline_thresholds
from core.diagnosis.judge import excess_of
from core.diagnosis.registry import EFFECTS
from core.diagnosis.search import _on_its_signature
from core.diagnosis.state import Candidate
from core.diagnosis.structure import Structure
from core.pi import PIModel
from core.recordings import Recording

FS = 200.0  # Hz
#: A small PI plant (output range about 20).
PLANT = PIModel(0.5, [10.0 * i for i in range(1, 5)], [0.1 * np.exp(-0.2 * i)
                                                       for i in range(1, 5)])


def _periodic() -> Recording:
    """1 s at rest, then 7 periods of a 1 Hz cosine of amplitude 50, a linear drift of 5 %
    of the output range over the record, and 0.5 % noise."""
    t = np.arange(int(8 * FS)) / FS
    u = np.where(t < 1.0, 0.0, -50.0 * np.cos(2 * np.pi * (t - 1.0)))
    y0 = PLANT(u)
    yr = float(np.ptp(y0))
    rng = np.random.default_rng(3)
    y = y0 + 0.05 * yr * t / t[-1] + 0.005 * yr * rng.standard_normal(t.size)
    return Recording(t=t, u=u, y=y, name="periodic")


def test_a_candidate_judged_cycle_to_cycle_counts_the_noise_twice() -> None:
    rec = _periodic()
    tr, te, _ = split_masks([rec], None, None)
    ctx = FitContext([rec], tr, te)
    cur = ctx.fit(Structure(tuple(float(x) for x in baseline_thresholds([rec], tr, 3)),
                            ((),)))
    sig = EFFECTS["drift"].signature
    assert sig is not None and sig(ctx) is not None and sig(ctx).previous is not None
    got = build_candidate(ctx, "drift", cur)
    assert got is not None
    judged = _on_its_signature(ctx, cur, Candidate("drift", *got,
                                                   heldout=screen_gain(got[0], cur)))
    assert judged is not None and judged.where is not None
    assert judged.differenced
    noise = 0.1
    assert excess_of(judged, 9.0, noise, strict=False) == pytest.approx(
        judged.heldout.mse_before - 2 * noise**2)
    assert floor_mse(noise, True) == 2 * noise**2
