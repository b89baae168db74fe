"""The null distribution of the same-history test (issue 30): the rows of
:func:`core.diagnosis.periodic.same_history` are compared as each row's change from a row
of an earlier branch with the same input history, and that change is judged by the batch
means Diebold-Mariano z of :func:`core.diagnosis.stats.heldout_comparison`, which takes its
batch means as independent.

Before: every later branch was compared with the first branch of its history, a reference
they all shared; under the null their differences correlate by +1/2, the batch means
under-estimate the variance of their mean, and the z of pure noise spread 1.8 times too
wide (one in six above 1.645; a Menegotto-Pinto null reached z 1.92). Now the branches of
one history are paired half a group apart, each branch in one pair at most: the
differences are independent under the null and the z of pure noise is standard normal."""

from __future__ import annotations

import numpy as np

from core.diagnosis.periodic import same_history
from core.diagnosis.stats import heldout_comparison
from core.pi import PIModel
from core.recordings import Recording

FS = 500.0  # Hz
PLANT = PIModel(0.5, [10.0 * i for i in range(1, 9)], [0.12 * np.exp(-0.2 * i)
                                                       for i in range(1, 9)])


def _tapered(cycles_full: int = 8, ramp: float = 2.5) -> Recording:
    """A 1 Hz sine of amplitude 80 whose envelope rises over ``ramp`` cycles, holds
    ``cycles_full`` cycles at full amplitude and falls again (many branches of one history,
    too few for nothing: the same-history rows, not cycle to cycle, are what is tested)."""
    total = cycles_full + 2 * ramp
    t = np.arange(int(total * FS)) / FS
    u = 80.0 * np.clip(np.minimum(t, total - t) / ramp, 0.0, 1.0) * np.sin(2 * np.pi * t)
    return Recording(t=t, u=u, y=PLANT(u), name="tapered")


def test_each_branch_is_in_one_pair_at_most() -> None:
    """No branch's noise enters two differences: the reference rows are never compared rows
    themselves (not a star around the first branch, not a chain)."""
    rec = _tapered()
    sig = same_history([rec])
    assert sig is not None and sig.previous is not None
    m, prev = sig.masks[0], sig.previous[0]
    assert "each branch compared once" in sig.words
    w = np.flatnonzero(m)
    assert not m[prev[w]].any()
    # the pairs span half the full-amplitude stretch (4 s of 8), not one period
    assert np.min(rec.t[w] - rec.t[prev[w]]) >= 3.9


def test_pure_noise_gives_a_z_no_wider_than_standard_normal() -> None:
    """White noise as the residual (the base's misfit cancels exactly on these rows) and a
    drift's predicted change that grows with the time between the two rows, too small to
    matter (the z is scale-free in it): the 300 z of 300 noise draws are at most standard
    normal (spread 0.99, 5.7 % above 1.645). With the first branch as a shared reference
    their spread was 1.8 and one in six exceeded 1.645; chained, 0.4 (conservative)."""
    rec = _tapered()
    sig = same_history([rec])
    assert sig is not None and sig.previous is not None
    w = np.flatnonzero(sig.masks[0])
    p = sig.previous[0][w]
    change = 1e-6 * (rec.t[w] - rec.t[p])  # the candidate's predicted change, e[w] - e[p]
    rng = np.random.default_rng(7)
    z = []
    for _ in range(300):
        e = rng.standard_normal(rec.n_samples)
        d = e[w] - e[p]
        z.append(heldout_comparison([d], [d - change]).z)
    z_arr = np.asarray(z)
    assert np.std(z_arr) < 1.15
    assert np.mean(z_arr > 1.645) < 0.08
