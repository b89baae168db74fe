"""Creep on a recording without a hold: the smallest creep the cycle-to-cycle test could
find, and the report's words when that is above what devices show (issue 30, the shipped
piezo recording with concealed creep: one input step, then a 1 Hz sine).

Before: the creep candidate was judged from cycle to cycle, found nothing and the report
said nothing of creep at all, although its settling there is far below the recording's own
change from cycle to cycle (a creep below about 24 % per decade could not have shown)."""

from __future__ import annotations

import math

import numpy as np

from core.diagnosis import diagnose
from core.diagnosis.acceptance import RULE
from core.diagnosis.creepsettling import PLAUSIBLE_CREEP, settling_limit
from core.pi import PIModel
from core.recordings import Recording


def test_the_limit_is_where_the_lags_settling_removes_min_gain_of_the_changes() -> None:
    """One lag of tau (from the steady state of the first row, 0) under a prediction that
    steps to D after the first row: its output ``D (1 - exp(-t / tau))`` changes over one
    period P by ``D exp(-t / tau) (exp(P / tau) - 1)``; with residual changes of RMS ``s``
    the creep ``gamma`` with ``gamma^2 |dL|^2 / (s^2 n + gamma^2 |dL|^2) = min_gain`` is
    the limit."""
    dt, period, tau, d, s = 1e-3, 1.0, 3.0, 2.0, 0.05
    t = np.arange(int(8 / dt)) * dt
    pred = np.full(t.size, d)
    pred[0] = 0.0  # (the first-order hold ramps to D over the first interval: a step at dt/2)
    # the residual flips sign from one period to the next: every change is s exactly
    res = np.where((t // period) % 2 == 0, s, -s) / 2.0
    k = int(round(period / dt))
    a = np.arange(2 * k, t.size)
    b = a - k
    dl = d * np.exp(-(t[a] - dt / 2) / tau) * (np.exp(period / tau) - 1.0)
    g = RULE.min_gain
    want = math.sqrt(g / (1 - g) * a.size * s**2 / float(np.sum(dl**2)))
    got = settling_limit([pred], [res], [(a, b)], [tau], [dt])
    assert got == np.float64(got) and abs(got / want - 1.0) < 2e-3


def test_without_pairs_or_change_of_the_lags_the_limit_is_infinite() -> None:
    pred = np.ones(100)
    a = np.arange(50, 100)
    assert settling_limit([pred], [np.zeros(100)], [(a[:0], a[:0])], [1.0], [0.01]) == math.inf
    # a prediction that has settled already (the lag from its steady state): no change
    assert settling_limit([np.zeros(100)], [np.ones(100)], [(a, a - 10)], [1.0],
                          [0.01]) == math.inf


FS = 1000.0  # Hz
#: A piezo-like plant (8 plays, output range about 30).
PLANT = PIModel(0.5, [10.0 * i for i in range(1, 9)], [0.12 * np.exp(-0.2 * i)
                                                       for i in range(1, 9)])


def _jump_into_a_sine(seed: int) -> Recording:
    """Like the shipped piezo recording: 1 s at rest, one jump into a 1 Hz sine about the
    rest level (its mean does not move: the slow lags hardly settle from cycle to cycle),
    7 cycles, noise 0.3 % of the range."""
    t = np.arange(int(8 * FS)) / FS
    u = np.where(t < 1.0, 0.0, 80.0 * np.sin(2 * np.pi * (t - 1.0) - np.pi / 3))
    y = PLANT(u)
    rng = np.random.default_rng(seed)
    y = y + 0.003 * float(np.ptp(y)) * rng.standard_normal(y.size)
    return Recording(t=t, u=u, y=y, name=f"jump-{seed}")


def test_a_jump_into_a_sine_says_why_creep_is_untestable_and_what_would_decide() -> None:
    rec = _jump_into_a_sine(1)
    res = diagnose(rec, n_operators=10, effects=["creep"], auto_resolution=False)
    assert res.effects == []
    creep = [u for u in res.untestable if u.name == "creep"]
    assert len(creep) == 1
    entry = creep[0]
    # the smallest creep the cycles could show is above what devices show
    assert entry.parameters["gamma_per_decade_below"] > PLAUSIBLE_CREEP
    # where its signature would be: the one step, the repeating fast lags, the cycles
    assert "step at 1 s is one event" in entry.reason
    assert f"fewer than the {RULE.min_events}" in entry.reason
    assert "repeat with every cycle" in entry.reason
    assert "from cycle to cycle" in entry.reason
    assert "holds of 3-30 s" in entry.experiment
    assert "Untestable: creep:" in res.summary()
