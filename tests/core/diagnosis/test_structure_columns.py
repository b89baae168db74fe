"""The columns of a term read from the PI-stage output (creep) under output dynamics
(core.diagnosis.structure): where the structure fit puts them in its design matrix, and from
which sample it runs their dynamics, must agree with ``term_columns_at`` (what a term fitted
on changes between training rows is fitted on, core.diagnosis.changes): weights fitted on
the one and held in the other must mean the same thing.

Both are checked against a reference of their own: the term's columns on every sample,
each passed through the stages the exact model chains (core.stages: Lag, Resonance, Delay,
run from sample 0), on training rows that begin late in the record (the structure fit then
starts its filters late, from where their start transient has died out)."""

from __future__ import annotations

import numpy as np
import pytest

import core.diagnosis.structure as st
from core.diagnosis.registry import TermFit, TermRows, dynamics_of, term_of
from core.pi import PIModel
from core.recordings import Recording

FS = 1000.0  # Hz
PLANT = PIModel(0.5, [10.0 * i for i in range(1, 6)], [0.1 * np.exp(-0.3 * i)
                                                        for i in range(1, 6)])
#: the creep lags (s)
CREEP = (0.01, 0.1, 1.0)


def _record() -> Recording:
    """4 s: a staircase of input steps with holds (the dynamics ring and settle after each),
    then a 2 Hz cosine."""
    t = np.arange(int(4 * FS)) / FS
    steps = np.repeat([0.0, 30.0, -20.0, 45.0, 10.0, -40.0, 0.0, 25.0], 250)
    u = np.where(t < 2.0, np.resize(steps, t.size), 40.0 * np.cos(2 * np.pi * 2.0 * t))
    y = PLANT(u) + 1e-3 * np.random.default_rng(4).standard_normal(t.size)
    return Recording(t=t, u=u, y=y, name="steps")


def _train(n: int) -> np.ndarray:
    """Training rows from sample 1700 on, in alternating blocks of 300 samples."""
    m = np.zeros(n, dtype=bool)
    for a in range(1700, n, 600):
        m[a : a + 300] = True
    return m


def _reference(s: st.Structure, rec: Recording, x: np.ndarray, rows: np.ndarray,
               center: float, half: float) -> np.ndarray:
    """The creep columns on every sample up to the last row, each through the exact stages
    of ``s.dynamics`` in series from sample 0, on ``rows``."""
    last = int(rows[-1]) + 1
    every = np.arange(last)
    cols = term_of("creep").columns(s.term("creep"),
                                    TermRows(rec, 0, every, x[:last], TermFit(1, center, half)))
    out = np.empty((last, cols.shape[1]))
    for j in range(cols.shape[1]):
        c = cols[:, j]
        for name, v in st.dynamics_stages(s.dynamics):
            c = np.asarray(dynamics_of(name).model(v)(c, dt=rec.dt))
        out[:, j] = c
    return out[rows]


@pytest.mark.parametrize("dyn", [
    ("lag", 0.004),
    ("resonance", 100.0, 0.1),
    ("delay", 0.0123),
    st.pack_dynamics(["lag", "resonance"], [0.003, 100.0, 0.1]),
], ids=["lag", "resonance", "delay", "lag+resonance"])
def test_the_fit_and_term_columns_at_agree_under_output_dynamics(dyn, monkeypatch) -> None:
    rec = _record()
    train = _train(rec.n_samples)
    rows = np.flatnonzero(train)
    s = st.Structure((10.0, 20.0, 30.0, 40.0), ((),), dynamics=dyn).with_term("creep", CREEP)
    x = PLANT(rec.u)  # a PI-stage output to read (held fixed: one pass, no refresh)
    # the design matrix the structure fit solves (caught at its solve)
    seen: dict = {}
    solve = st._solve_holding

    def spy(s_, X, *args, **kwargs):
        seen["X"] = X.copy()
        return solve(s_, X, *args, **kwargs)

    monkeypatch.setattr(st, "_solve_holding", spy)
    st.fit_structure(s, [rec], [train], st.BankCache(), [x], iterations=1)
    X = seen["X"]
    # the training output's centre and half range, as the fit forms them
    lo, hi = float(rec.y[train].min()), float(rec.y[train].max())
    center, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    ref = _reference(s, rec, x, rows, center, half)
    scale = np.max(np.abs(ref), axis=0)
    at = st.term_columns_at(s, "creep", [rec], 0, rows, x, center, half)
    assert at.shape == ref.shape
    np.testing.assert_allclose(at / scale, ref / scale, rtol=0, atol=1e-9)
    # where the fit puts the term: after the base's columns, at the place its solved
    # weights are read from (and held weights written to)
    nb = len(s.thresholds) + 1
    (entry,) = [t for t in st._term_columns(s, nb, 1)[0] if t[0] == "creep"]
    a, b = entry[3], entry[4]
    assert b - a == len(CREEP) and X.shape[0] == rows.size and b < X.shape[1]
    np.testing.assert_allclose(X[:, a:b] / scale, ref / scale, rtol=0, atol=1e-9)
    assert st._filter_start(dyn, rec.dt, int(rows[0])) > 0  # the fit started late
