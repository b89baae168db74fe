"""A candidate judged where it lives (core.diagnosis.search._on_its_signature) on rows
compared with an earlier row of the same input history (a drift from cycle to cycle of a
repeated input) is marked with a noise factor of 2: the white noise enters such a change twice, so
the excess its 20 % share is counted in subtracts 2 noise², not noise²
(:func:`~core.diagnosis.acceptance.floor_mse`, :func:`~core.diagnosis.state.excess_of`)."""

from __future__ import annotations

import numpy as np
import pytest

from core.diagnosis.acceptance import floor_mse
from core.diagnosis.candidates import build_candidate
from core.diagnosis.context import FitContext
from core.diagnosis.crossfitting import screen_gain
from core.diagnosis.data import split_masks
from core.diagnosis.grid import baseline_thresholds
from core.diagnosis.registry import EFFECTS
from core.diagnosis.search import _on_its_signature
from core.diagnosis.state import Candidate, excess_of
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
    assert judged.noise_factor == 2.0
    noise = 0.1
    assert excess_of(judged, 9.0, noise, strict=False) == pytest.approx(
        judged.heldout.mse_before - 2 * noise**2)
    assert floor_mse(noise, 2.0) == 2 * noise**2


def test_the_search_leads_with_the_excess_the_judge_counts(monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    """With strict hold-out the search lets a passing family bound the later ones
    (search_round's lead); it decides that with the excess the judge's verdict counts
    (state.excess_of), not its own: on rows compared with an earlier row the floor is twice
    the noise variance. Before, the search subtracted noise² once: a candidate removing 0.12
    of an MSE of 1 with noise 0.5 met the share for the judge (20 % of 0.5) but not for the
    lead (20 % of 0.75)."""
    from types import SimpleNamespace

    from core.diagnosis import judge, search
    from core.diagnosis.acceptance import decide as real_decide
    from core.diagnosis.stats import HeldOut

    noise = 0.5
    held = HeldOut(1.0, 0.88, 0.12, 8.0, 1e-9, 40)
    rec = _periodic()
    seen: list[tuple[float, bool]] = []

    def spy(h, excess, *args, **kwargs):  # type: ignore[no-untyped-def]
        d = real_decide(h, excess, *args, **kwargs)
        seen.append((excess, d.passes))
        return d

    monkeypatch.setattr(search, "build_candidate", lambda ctx, name, cur: (None, {}, {}))
    monkeypatch.setattr(search, "screen_gain", lambda fit, cur: held)
    monkeypatch.setattr(search, "candidate_evidence", lambda run, cur, c, rnd, frac: Candidate(
        c.name, c.fit, {}, {}, heldout=held, where="test rows one cycle apart",
        noise_factor=2.0))
    monkeypatch.setattr(search, "decide", spy)
    ctx = SimpleNamespace(strict=True, test_res=lambda f: [rec.y[:10] * 0.0 + 3.0])
    run = SimpleNamespace(ctx=ctx, noise=noise, step=lambda *a: None)
    cur = SimpleNamespace(pred=[rec.y])
    cands, _ = search.search_round(run, cur, ["drift"], 0)  # type: ignore[arg-type]
    judged = cands["drift"]
    # the judge's excess: its verdict counts it with this same function
    assert judge.excess_of is excess_of
    want = excess_of(judged, 9.0, noise, strict=True)
    assert want == pytest.approx(held.mse_before - floor_mse(noise, 2.0)) == 0.5
    assert seen == [(pytest.approx(want), True)]
