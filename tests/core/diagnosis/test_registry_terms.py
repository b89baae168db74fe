"""Static effects own their terms (issue 34): a static effect is one registration with its
columns, bounds, coefficients and stage, and the structure fit, the model builder, the
leave-one-recording-out refit and the diagnosis loop over the registered terms without
naming any. A toy effect registered here, and nowhere else, is fitted, built, switched off
and found."""

from __future__ import annotations

import numpy as np
import pytest

from core.base import Chain
from core.diagnosis import Structure, diagnose
from core.diagnosis.registry import (
    EFFECTS,
    DiagnosableEffect,
    StaticTerm,
    TermFit,
    TermRows,
    static_terms,
)
from core.diagnosis.structure import baseline_thresholds, build_model, fit_structure
from core.pi import PIModel
from core.recordings import Recording
from core.stages import Asymmetry, Creep, Drift, Offset

PLANT = PIModel(0.5, [4.0, 12.0], [0.4, 0.2])


# ------------------------------------------------------------------ a toy effect, one module
def _trend_columns(on: bool, rows: TermRows) -> np.ndarray:
    """One column shared by every recording: its time mapped onto [-1, 1]."""
    t = rows.record.t
    return (2.0 * (t - t[0]) / (t[-1] - t[0]) - 1.0)[rows.rows, None]


TREND_TERM = StaticTerm(
    off=False,
    width=lambda on, n_records: 1 if on else 0,
    columns=_trend_columns,
    coefficients=lambda on, w, fit: float(w[0]),
    stage=lambda on, c, k, record: Drift([c], float(record.t[-1] - record.t[0])),
)


def _build_trend(ctx, cur):
    s = cur.structure
    if s.term("trend"):
        return None
    fit = ctx.fit(s.with_term("trend", True), cur)
    return fit, {"half_rise": fit.terms["trend"]}, {}


TREND = DiagnosableEffect(
    "trend", "slow",
    explanation="A thermal ramp common to every recording: the same rise over each.",
    equation="y = x + a (2 t / T - 1)",
    build=_build_trend, model_type=Drift, structure_field="terms", time_dependent=True,
    linear=True, stage_order=7, term=TREND_TERM)


def _recordings(rise: float, n: int = 2, seed: int = 3) -> tuple[list[Recording], PIModel]:
    """Two recordings of a PI on the diagnosis' own baseline grid (so the base is exact)
    plus a ramp of ``rise`` over each, noise 0.01; and the PI."""
    rng = np.random.default_rng(seed)
    t = np.arange(0, 20.0, 2e-3)
    us = [40.0 * np.sin(2 * np.pi * (0.5 + 0.2 * k) * t) * (1 - np.exp(-t)) for k in range(n)]
    r = baseline_thresholds([Recording(t, u, u) for u in us],
                            [np.ones(t.size, dtype=bool)] * n, 8)
    plant = PIModel(0.5, r, np.linspace(0.3, 0.05, r.size))
    recs = [Recording(t, u, plant(u) + rise * (2 * t / t[-1] - 1)
                      + 0.01 * rng.standard_normal(t.size), f"run {k}")
            for k, u in enumerate(us)]
    return recs, plant


def test_a_registered_term_is_fitted_and_built_by_the_loops(monkeypatch) -> None:
    """The toy term's column joins the solve and its stage joins the chain in its
    stage order; its coefficient is the rise put into the data; the offset term, switched
    off, is the one common bias."""
    monkeypatch.setitem(EFFECTS, "trend", TREND)
    assert [n for n, _, _ in static_terms()] == ["asymmetry", "creep", "offset", "drift",
                                                "trend"]
    recs, plant = _recordings(0.8)
    train = [np.ones(r.n_samples, dtype=bool) for r in recs]
    r = tuple(float(v) for v in baseline_thresholds(recs, train, 8))
    base = Structure(r, ((),) * len(recs))
    s = base.with_term("trend", True)
    assert s.effects == ["trend"] and base.effects == []
    assert s.without("trend", base) == base
    assert s.with_term("trend", False) == base  # switched off by its off settings
    f0 = fit_structure(base, recs, train)
    f1 = fit_structure(s, recs, train)
    assert set(f0.terms) == {"offset"} and set(f1.terms) == {"offset", "trend"}
    assert f1.terms["trend"] == pytest.approx(0.8, rel=0.01)
    assert f1.train_rss < 1.2 * f1.n_train * 0.01**2 < 0.01 * f0.train_rss  # at the noise
    chain = f1.models[1]
    assert isinstance(chain, Chain)
    assert [type(m) for m in chain.stages][-2:] == [Offset, Drift]
    ref = plant(recs[1].u) + 0.8 * (2 * recs[1].t / recs[1].t[-1] - 1)
    assert np.max(np.abs(f1.pred[1] - ref)) < 0.01


def test_a_registered_term_is_found_by_the_diagnosis(monkeypatch) -> None:
    monkeypatch.setitem(EFFECTS, "trend", TREND)
    res = diagnose(_recordings(0.5)[0], effects=["trend"], base="pi")
    assert [f.name for f in res.effects] == ["trend"]
    assert res.effects[0].parameters["half_rise"] == pytest.approx(0.5, rel=0.05)
    assert any(isinstance(m, Drift) for m in res.model.stages)


def test_the_moved_terms_build_their_stages_in_the_chain_order() -> None:
    """asymmetry and creep before the output dynamics, offset and drift after, each term's
    coefficients as its own stage (an independent chain of the core models)."""
    from core.diagnosis.effects.asymmetry import MapCoefficients
    from core.stages import Lag

    t = np.arange(3000) * 1e-3
    rec = Recording(t, 30 * np.sin(2 * np.pi * 2 * t), np.zeros_like(t))
    s = (Structure((4.0, 12.0), ((),), dynamics=("lag", 0.01))
         .with_term("asymmetry", True).with_term("creep", (0.1, 1.0)).with_term("drift", 2))
    assert s.effects == ["asymmetry", "creep", "lag", "drift"]
    coef = {"asymmetry": MapCoefficients(np.array([0.1, -0.05]), 1.0, 20.0),
            "creep": np.array([0.02, -0.01]), "offset": np.array([0.3]),
            "drift": [np.array([0.2, 0.1])]}
    m = build_model(s, 0, 0.5, np.array([0.4, 0.2]), coef, rec)
    ref = Chain.of(PLANT, Asymmetry([0.1, -0.05], 1.0, 20.0), Creep([0.1, 1.0], [0.02, 0.0]),
                   Lag(0.01), Offset(0.3), Drift([0.2, 0.1], float(t[-1])))
    assert [type(a) for a in m.stages] == [type(b) for b in ref.stages]
    np.testing.assert_allclose(m(rec.u, dt=1e-3), ref(rec.u, dt=1e-3), rtol=0, atol=1e-12)


def test_the_moved_terms_columns_and_bounds() -> None:
    """Each moved term's columns against a second implementation: the offset's indicator,
    the drift's Legendre block, the output map's normalised powers, the creep bank's lags
    (nonnegative weights)."""
    t = np.arange(500) * 1e-2
    rec = Recording(t, np.sin(t), np.sin(t))
    rows = np.arange(0, 500, 7)
    x = 3.0 + 2.0 * np.sin(0.7 * t)
    fit = TermFit(3, 3.0, 2.0)
    terms = {n: tm for n, tm, _ in static_terms()}
    off = terms["offset"].columns(True, TermRows(rec, 1, rows, None, fit))
    assert off.shape == (rows.size, 3) and np.all(off[:, 1] == 1) and not off[:, [0, 2]].any()
    assert np.all(terms["offset"].columns(False, TermRows(rec, 1, rows, None, fit)) == 1)
    d = terms["drift"].columns(2, TermRows(rec, 2, rows, None, fit))
    sc = 2 * t[rows] / t[-1] - 1
    np.testing.assert_allclose(d[:, 4:], np.column_stack((sc, 1.5 * sc**2 - 0.5)), atol=1e-12)
    assert not d[:, :4].any()
    q = np.sin(0.7 * t)
    a = terms["asymmetry"].columns(True, TermRows(rec, 0, rows, x, fit))
    np.testing.assert_allclose(a, np.column_stack((q**2, q**3)), atol=1e-12)
    c = terms["creep"].columns((0.5,), TermRows(rec, 0, rows, x, fit))
    # a unit lag from the steady state of the first sample, by scipy's own discretisation
    from scipy.signal import cont2discrete, lfilter, lfilter_zi

    b, a_, _ = cont2discrete(([1.0], [0.5, 1.0]), 1e-2, method="foh")
    b = np.ravel(b)
    want = lfilter(b, a_, x, zi=lfilter_zi(b, a_) * x[0])[0] - x
    np.testing.assert_allclose(c[:, 0], want, atol=1e-9)
    assert terms["creep"].lower == 0.0 and terms["drift"].lower == -np.inf


def test_deciding_experiments_are_declared_by_the_effects(monkeypatch) -> None:
    """The experiment that separates two look-alikes is declared by one of the pair in its
    own registration (specs.DECIDING_EXPERIMENT reads them): every pair names two registered
    effects, once; a new effect's pair is read without touching specs.py."""
    from core.diagnosis.specs import DECIDING_EXPERIMENT

    pairs = [frozenset({n, o}) for n, e in EFFECTS.items() for o, _ in e.deciding]
    assert len(pairs) == len(set(pairs)) == len(DECIDING_EXPERIMENT) == 11
    assert all(len(p) == 2 and p <= set(EFFECTS) for p in pairs)
    assert "staircase" in DECIDING_EXPERIMENT[frozenset({"drift", "creep"})]
    import dataclasses

    monkeypatch.setitem(EFFECTS, "trend", dataclasses.replace(
        TREND, deciding=(("drift", "recordings of several lengths"),)))
    assert DECIDING_EXPERIMENT.get(frozenset({"drift", "trend"})) == "recordings of several lengths"
    assert DECIDING_EXPERIMENT.get(frozenset({"lag", "trend"})) is None
