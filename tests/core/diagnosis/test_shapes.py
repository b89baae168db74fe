"""Loop-shape physics inside the effect search: saturation and dead zones.

References: generated truths (core models with a known dead band and saturation, known noise),
the shipped B-H loops, and the tanh-envelope GPI of ``core.fitting`` fitted on the same rows
(a second implementation of the same model class)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from core.base import Chain, model_from_dict
from core.deadzone import DeadZoneMap
from core.diagnosis import diagnose
from core.diagnosis.shapes import apply_shape, describe_shape, hysteresis_model
from core.exceptions import FitWarning
from core.export_c import generate_c
from core.fitting import TanhGPIRegressor
from core.gpi import DeadZoneGPI, TanhEnvelope, TanhGPI
from core.models import fit_kinds
from core.pi import PIModel
from core.recordings import Recording
from core.stages import Lag

BH = Path(__file__).parents[3] / "examples" / "data" / "bh_loops"
SHAPES = {"saturation", "dead-zone"}


def _triangles(peaks, n_per: int) -> np.ndarray:
    u = np.concatenate([np.linspace(a, b, n_per, endpoint=False)
                        for a, b in zip(peaks[:-1], peaks[1:], strict=True)])
    return np.r_[u, peaks[-1]]


def _pct(res, fit) -> float:
    return 100.0 * res.heldout_rmse(fit) / res.y_range


def _thresholded_actuator(noise: float = 0.025, seed: int = 0):
    """A drive 0..10 V that does nothing below 3 V (dead band on one side) and saturates
    towards the top: ``20 · P[tanh(0.45 γ(u) - 1.2)]``, white noise ``noise`` × range."""
    dz = DeadZoneMap([0.0, 3.0], [0.0, 1.0])
    env = TanhEnvelope([1, 0.45, -1.2, 0], [1, 0.45, -1.2, 0])
    r = np.linspace(0.02, 0.6, 8)
    truth = Chain.of(dz, TanhGPI(PIModel(1.0, r, 0.8 * np.exp(-3 * r)), env))
    u = _triangles([10, 0, 7, 1, 10, 3, 8, 0, 5, 0.5, 10, 0], 400)
    y0 = 20 * truth(u)
    sigma = noise * float(np.ptp(y0))
    y = y0 + sigma * np.random.default_rng(seed).standard_normal(u.size)
    return Recording(np.arange(u.size) * 1e-3, u, y, name="thresholded"), sigma


def _roundtrip_inverts_exports(model, y_desired: np.ndarray, dt: float | None) -> None:
    """The found model serialises, inverts (M(M^-1 y) = y) and exports to C."""
    m2 = model_from_dict(model.to_dict())
    u = y_desired * 0 + np.linspace(0, 1, y_desired.size)
    assert np.allclose(m2(u, dt=dt), model(u, dt=dt))
    inv = model.inverse()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        back = model(inv(y_desired, dt=dt), dt=dt)
    assert np.max(np.abs(back - y_desired)) < 1e-6 * np.ptp(y_desired)
    code = generate_c(model, dt=dt) if dt is not None else generate_c(model)
    assert "tanh" in code.source or "deadzone" in code.source.lower()


@pytest.mark.slow
def test_thresholded_actuator_names_the_loop_shape_and_reaches_the_noise_floor() -> None:
    """Issue 8, measured failure 2: on a saturating, one-sided loop with a dead band the PI
    baseline misses ~12 % of the range, ~5 times the noise; it used to say "No missing
    physics detected". Now both are named (the band's edge within 0.5 V of the truth) and
    the final model is at the noise floor (the injected sigma, not the estimated floor).
    Measured: PI 11.8 %, + saturation 2.65 %, + dead-zone (low side, below 2.77 V) 2.34 % of
    range = 1.05 sigma."""
    rec, sigma = _thresholded_actuator()
    res = diagnose(rec)
    base = res.heldout_rmse(res.baseline)
    assert _pct(res, res.baseline) > 8.0 and base > 4.0 * sigma
    names = [e.name for e in res.effects]
    assert names == ["saturation", "dead-zone"], names
    band = res.effects[1].parameters
    assert band["side"] == "low" and 2.5 < band["breakpoints"][0] < 3.5  # truth: 3 V
    assert "dead band below" in band["dead_band"]
    assert res.heldout_rmse(res.final) < 1.2 * sigma
    assert res.adequacy is not None and res.adequacy.adequate
    yd = np.linspace(0.2, 0.8, 200) * np.ptp(rec.y) + rec.y.min()
    _roundtrip_inverts_exports(res.model, yd, rec.dt)


@pytest.mark.parametrize(("name", "limit"), [("M130-27s_GO_steel.csv", 4.6),
                                             ("MnZn_ferrite.csv", 2.5)])
def test_bh_loops_name_saturation_and_reach_the_generalized_fit(name, limit) -> None:
    """Shipped B-H loops (no time axis, one recording per loop): saturation is the first
    effect, and the diagnosed model reaches what the tanh-envelope GPI of core.fitting
    reaches on the same training rows (scored on the same held-out rows). Measured
    (interleaved split): GO steel PI 13.0 % -> 4.04 % (tanh GPI fit 4.82 %), MnZn ferrite
    11.7 % -> 1.71 % (3.24 %)."""
    res = diagnose(str(BH / name))
    assert res.effects and res.effects[0].name == "saturation"
    assert _pct(res, res.baseline) > 9.0
    final = _pct(res, res.final)
    assert final <= limit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FitWarning)
        est = TanhGPIRegressor(constraint="slopes").fit(
            [r.u for r in res.records], [r.y for r in res.records], train=res.train,
            test=res.test)
    e = np.concatenate([(r.y - p)[m] for r, p, m in zip(
        res.records, est.predict([r.u for r in res.records]), res.test, strict=True)])
    second = 100 * float(np.sqrt(np.mean(e * e))) / res.y_range
    assert final <= 1.05 * second
    assert res.adequacy is not None and "saturation" in res.adequacy.text
    assert isinstance(res.model, Chain) and isinstance(res.model.stages[0], TanhGPI)
    yd = np.linspace(-0.5, 0.5, 100) * np.ptp(res.records[0].y)
    _roundtrip_inverts_exports(res.model, yd, None)


def test_adequacy_tries_every_registered_fit_kind() -> None:
    """Without the loop-shape effects (asymmetry only) the MnZn ferrite stays inadequate and
    the verdict fits every fit kind of the registry except the base PI."""
    res = diagnose(str(BH / "MnZn_ferrite.csv"), effects=["asymmetry"], n_operators=10,
                   auto_resolution=False)
    ad = res.adequacy
    assert ad is not None and not ad.adequate
    assert {f.model for f in ad.loop_shapes} == set(fit_kinds()) - {"pi"}
    assert "saturation" in ad.text


def test_null_pi_plant_claims_no_loop_shape() -> None:
    """A classical PI plant (several amplitudes, white noise): nothing to claim."""
    u = _triangles([0, 60, -60, 30, -40, 60, -20, 10, -60, 0], 250)
    r = np.linspace(4, 56, 10)
    y = PIModel(0.4, r, 0.05 * np.exp(-r / 30))(u)
    y = y + 0.005 * np.ptp(y) * np.random.default_rng(3).standard_normal(u.size)
    res = diagnose(Recording(np.arange(u.size) * 5e-4, u, y, name="null"),
                   effects=["saturation", "dead-zone", "asymmetry"])
    assert not res.effects, [e.name for e in res.effects]
    tested = {r["effect"] for r in res.rounds}
    assert SHAPES <= tested


def test_a_single_branch_cannot_test_a_loop_shape() -> None:
    """One monotone travel: any monotone curve is a PI's first branch, so the loop shape is
    untestable (with the reason), not claimed."""
    u = np.linspace(0, 10, 800)
    y = np.tanh(0.3 * u) + 0.001 * np.random.default_rng(0).standard_normal(u.size)
    res = diagnose(Recording(np.arange(u.size) * 1e-3, u, y, name="ramp"),
                   effects=["saturation", "dead-zone"])
    why = {x.name: x.reason for x in res.untestable}
    assert SHAPES <= set(why) and "single branch" in why["saturation"]
    assert not res.effects


@pytest.mark.slow
def test_lag_stacks_on_a_saturating_base() -> None:
    """Saturation and a first-order lag at once (timed triangles of several amplitudes): the
    lag stacks on the loop-shape base, the final model holds both stages and inverts."""
    env = TanhEnvelope([1, 0.5, 0, 0], [1, 0.5, 0, 0])
    r = np.linspace(0.05, 0.8, 8)
    sat = TanhGPI(PIModel(1.0, r, 0.4 * np.exp(-2 * r)), env)
    dt, tau = 2e-4, 3e-3
    u = _triangles([0, 4, -4, 2, -3, 4, -1, 1, -4, 0], 250)
    y0 = 10 * Chain.of(sat, Lag(tau))(u, dt=dt)
    sigma = 0.002 * np.ptp(y0)
    y = y0 + sigma * np.random.default_rng(5).standard_normal(u.size)
    res = diagnose(Recording(np.arange(u.size) * dt, u, y, name="sat+lag"),
                   effects=["lag", "saturation"])
    assert [e.name for e in res.effects] == ["saturation", "lag"]
    assert res.effects[1].parameters["tau_s"] == pytest.approx(tau, rel=0.2)
    # measured 0.349 = 4.5 sigma: the envelope, fitted before the lag was in, is not
    # searched again (PI 2.68, saturation alone 1.52)
    assert res.heldout_rmse(res.final) < 0.2 * res.heldout_rmse(res.baseline)
    yd = np.linspace(-0.4, 0.4, 300) * np.ptp(y)
    _roundtrip_inverts_exports(res.model, yd, dt)


def test_shape_maps_are_the_core_models() -> None:
    """The structure's input maps evaluate as the core's TanhEnvelope / DeadZoneMap, and the
    hysteresis stage is the registered cascade (``gpi-tanh`` / ``gpi-deadzone``)."""
    u = np.linspace(-3, 5, 101)
    g = DeadZoneMap([-1.0, 0.0, 2.0], [0.5, 1.0, -0.9])
    tanh = ("tanh", 0.7, -0.2)
    dz = ("deadzone", tuple(g.thresholds), tuple(g.weights))
    assert np.allclose(apply_shape((tanh,), u), TanhEnvelope([1, .7, -.2, 0], [1, .7, -.2, 0])(u))
    assert np.allclose(apply_shape((dz,), u), g(u))
    assert np.allclose(apply_shape((dz, tanh), u), np.tanh(0.7 * g(u) - 0.2))
    pi = PIModel(1.0, [0.1, 0.2], [0.3, 0.1])
    assert isinstance(hysteresis_model((tanh,), pi), TanhGPI)
    assert isinstance(hysteresis_model((dz,), pi), DeadZoneGPI)
    both = hysteresis_model((dz, tanh), pi)
    assert np.allclose(both(u), pi(np.tanh(0.7 * g(u) - 0.2)))
    d = describe_shape(dz, -3, 5)
    # slopes 1.5 below -1, 1 on [-1, 2], 0.1 above 2: the last is a dead band
    assert d["breakpoints"] == [-1.0, 2.0]
    assert np.allclose(d["relative_slopes"], [1.0, 1 / 1.5, 0.1 / 1.5])
    assert "dead band above 2" in d["dead_band"]



def test_search_context_keeps_play_outputs_exact() -> None:
    """Long recordings are searched on every k-th sample plus every reversal: the loop-shape
    play bank at the kept samples equals the full-rate one (rate independence), and
    structures with time-dependent parts are searched on the full recording."""
    from core.diagnosis.candidates import search_context
    from core.diagnosis.context import FitContext
    from core.diagnosis.data import split_masks
    from core.diagnosis.grid import baseline_thresholds
    from core.diagnosis.structure import Structure

    t = np.arange(0, 6.0, 2e-4)
    u = 4 * np.sin(2 * np.pi * 1.3 * t) * (1 + 0.3 * np.sin(2 * np.pi * 0.21 * t))
    rec = Recording(t, u, np.tanh(u), name="long")
    tr, te, _ = split_masks([rec], None, None)
    ctx = FitContext([rec], tr, te)
    r = baseline_thresholds([rec], tr, 12)
    shape = (("tanh", 0.4, 0.1),)
    s = Structure(tuple(float(x) for x in r), ((),), shape=shape)
    cur = ctx.fit(s)
    sub, _ = search_context(ctx, cur)
    assert sub.records[0].n_samples < rec.n_samples / 2
    keep = np.isin(t, sub.records[0].t)
    full = ctx.cache.bank(0, rec, r, (), None, shape)
    dec = sub.cache.bank(0, sub.records[0], r, (), None, shape)
    assert np.array_equal(full[keep], dec)
    assert search_context(ctx, ctx.fit(s.with_(dynamics=("lag", 1e-3))))[0] is ctx


def test_long_recordings_still_compare_the_other_model_classes(monkeypatch) -> None:
    """Issue 16: "not tried on recordings this long" is not an answer. With the row limit
    set below this recording's training rows, the other classes are fitted on every k-th
    training row (the memory still runs over every sample) and compared all the same."""
    from core.diagnosis import adequacy

    rec, _ = _thresholded_actuator()
    monkeypatch.setattr(adequacy, "MAX_SAMPLES", 500)
    res = diagnose(rec, effects=["delay"])
    ad = res.adequacy
    assert not ad.adequate
    assert {f.model for f in ad.loop_shapes} >= {"mpi", "gpi-tanh", "preisach"}
    assert "this long" not in ad.text and "th training row" in ad.text
