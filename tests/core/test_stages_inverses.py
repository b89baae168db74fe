"""Every effect inverts: round trips forward(inverse(u)) = u (or the stated bound)."""

from __future__ import annotations

import threading
import warnings

import numpy as np
import pytest

from core.base import Chain
from core.exceptions import ClippedInputWarning, NotInvertibleError, ParameterError
from core.pi import PIModel
from core.stages import (
    Advance,
    Asymmetry,
    AsymmetryInverse,
    Creep,
    CreepInverse,
    Delay,
    Drift,
    InitialMemory,
    Lag,
    LagInverse,
    Offset,
    RateDependentPI,
    RateDependentPIInverse,
    Resonance,
    ResonanceInverse,
    causal_form,
    foh_filter,
)

DT = 1e-4
PI = PIModel(0.5, [10.0, 30.0, 60.0], [0.1, 0.08, 0.05])


def _u(n: int = 20_000, amp: float = 1.0) -> np.ndarray:
    t = np.arange(n) * DT
    return amp * (np.sin(2 * np.pi * 5 * t) + 0.3 * np.sin(2 * np.pi * 37 * t + 0.4))


EXACT = [
    Offset(-1.5),
    Drift([0.3, -0.1, 0.05], 1.2),
    Lag(2e-3),
    Lag(3e-5),  # tau < dt: the FOH zero is still inside the unit disc
    Creep([0.01, 0.1, 1.0], [0.02, 0.02, 0.03]),
    Creep([1e-4, 1e-3], [0.3, 0.4]),  # fast and heavy: still minimum phase
    Asymmetry([0.1, 0.02], 0.2, 2.0),
    RateDependentPI(1.0, [0.5, 1.0], [0.3, 0.2], 2e-5),
    InitialMemory(PIModel(1.0, [0.5, 1.0], [0.3, 0.2]), [2.0, -1.0]),
    InitialMemory(RateDependentPI(1.0, [0.5, 1.0], [0.3, 0.2], 2e-5), [2.0, -1.0]),
]


@pytest.mark.parametrize("model", EXACT, ids=lambda m: m.type_name)
def test_exact_inverses_round_trip_to_rounding(model) -> None:
    u = _u()
    inv = model.inverse()
    np.testing.assert_allclose(model(inv(u, dt=DT), dt=DT), u, rtol=0, atol=1e-12)
    # and the other way round: inverse(forward(x)) = x
    np.testing.assert_allclose(inv(model(u, dt=DT), dt=DT), u, rtol=0, atol=1e-11)
    # the inverse really does something (not the identity)
    assert np.max(np.abs(inv(u, dt=DT) - u)) > 1e-4


@pytest.mark.parametrize(
    "inv",
    [LagInverse(2e-3), CreepInverse([0.01, 0.1], [0.05, 0.02]),
     RateDependentPIInverse(1.0, [0.5, 1.0], [0.3, 0.2], 2e-5), AsymmetryInverse([0.1], 0, 2),
     ResonanceInverse(300.0, 0.05, 900.0), Drift([0.2], 0.5).inverse()],
    ids=lambda m: m.type_name,
)
def test_inverse_stages_continue_from_their_state(inv) -> None:
    u = _u(3000)
    y = inv(u, dt=DT)
    a = inv.simulate(u[:1234], dt=DT)
    b = inv.simulate(u[1234:], state=a.state, dt=DT)
    np.testing.assert_allclose(np.concatenate((a.y, b.y)), y, rtol=0, atol=1e-12)


def test_chain_inverse_is_the_reversed_inverses_and_round_trips() -> None:
    plant = Chain.of(PI, Asymmetry([0.05], 20.0, 40.0), Creep([0.01, 0.1], [0.02, 0.01]),
                     Lag(5e-4), Offset(0.3))
    inv = plant.inverse()
    assert [s.type_name for s in inv.stages] == [
        "offset", "lag-inverse", "creep-inverse", "asymmetry-inverse", "pi"]
    u = 20 + _u(amp=30.0)
    np.testing.assert_allclose(plant(inv(u, dt=DT), dt=DT), u, rtol=0, atol=1e-10)


def test_lag_inverse_is_the_exact_inverse_of_the_discrete_filter() -> None:
    # independent reference: the discretised lag's coefficients, swapped (b <-> a)
    import scipy.signal as ss

    y = _u()
    b, a, _ = ss.cont2discrete(([1.0], [2e-3, 1.0]), DT, method="foh")
    b = np.squeeze(b)
    x_ref = ss.lfilter(a, b, y, zi=ss.lfilter_zi(a, b) * y[0])[0]
    np.testing.assert_allclose(LagInverse(2e-3)(y, dt=DT), x_ref, rtol=0, atol=1e-10)


def test_creep_inverse_rules() -> None:
    with pytest.raises(NotInvertibleError, match="sum to 1 >= 1"):
        Creep([0.01, 0.1], [0.5, 0.5]).inverse()
    # with sum(weights) < 1 the discretised creep is minimum phase at every sampling: its
    # response at z = -1 stays positive and every zero of the bank lies inside the unit disc
    for dt in (1e-6, 1e-4, 1e-2, 1.0):
        bank = Creep([1e-4, 1e-3, 1e-2], [0.3, 0.3, 0.39]).bank(dt)
        assert bank.gain0 > 0 and bank.gain_at_nyquist() > 0
        num = np.poly1d([bank.g0])
        den = np.poly1d([1.0])
        for c, b0, b1, a1 in zip(bank.c, bank.b0, bank.b1, bank.a1, strict=True):
            sec = np.poly1d([1.0, a1])
            num = num * sec + np.poly1d([float(c) * b0, float(c) * b1]) * den
            den = den * sec
        assert np.max(np.abs(num.roots)) < 1
    with pytest.raises(ParameterError):
        Creep([1e-3], [0.2]).inverse().simulate(_u(10), state=(np.zeros(1),) * 2, dt=DT)


def _resonance_round_trip(fc: float, dt: float) -> tuple[float, float, float]:
    """(max error, stated bound, max distance from the documented roll-off) at ``dt``."""
    res = Resonance(300.0, 0.05)
    t = np.arange(0, 1.0, dt)  # starts at rest with zero slope: bounded curvature
    u = 1 - np.cos(2 * np.pi * 5 * t) + 0.3 * (1 - np.cos(2 * np.pi * 37 * t))
    inv = res.inverse(bandwidth_hz=fc)
    y = res(inv(u, dt=dt), dt=dt)
    ref, _ = foh_filter(u, *inv.rolloff(), dt)
    curv = np.max(np.abs(np.diff(u, 2))) / dt**2
    return float(np.max(np.abs(y - u))), inv.error_bound(curv), float(np.max(np.abs(y - ref)))


def test_resonance_inverse_error_bound_holds_and_tightens_with_bandwidth() -> None:
    errs = []
    for fc in (300.0, 600.0, 1000.0):
        e, bound, _ = _resonance_round_trip(fc, 2.5e-5)  # f_c dt <= 0.025
        assert e <= 1.05 * bound  # the stated (continuous-time) bound
        errs.append(e)
    assert errs[0] > errs[1] > errs[2]
    # sampling adds a second-order error: halving dt quarters the distance from L(s)
    d1 = _resonance_round_trip(1000.0, 1e-4)[2]
    d2 = _resonance_round_trip(1000.0, 5e-5)[2]
    assert 3.0 < d1 / d2 < 5.0
    # without compensation the mode's error is several times larger (default f_c = 4 f_n)
    res = Resonance(300.0, 0.05)
    u = _u()
    e_default = np.max(np.abs(res(res.inverse()(u, dt=DT), dt=DT) - u))
    assert np.max(np.abs(res(u, dt=DT) - u)) > 3 * e_default
    assert res.inverse().bandwidth_hz == 1200.0


def test_asymmetry_inverse_clips_outside_the_monotone_range_with_a_warning() -> None:
    asym = Asymmetry([0.0, -0.2], 0.0, 1.0)  # y = x - 0.2 x^3: increasing for |x| < 1.29
    lo, hi = asym.monotone_range()
    np.testing.assert_allclose([lo, hi], [-np.sqrt(1 / 0.6), np.sqrt(1 / 0.6)])
    inv = asym.inverse()
    y = np.linspace(-0.8, 0.8, 101)  # inside the image (max 0.86)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(asym(inv(y)), y, rtol=0, atol=1e-14)
    with pytest.warns(ClippedInputWarning, match="2 sample"):
        x = inv(np.array([-5.0, 0.0, 5.0]))
    np.testing.assert_allclose(x, [lo, 0.0, hi], rtol=0, atol=1e-15)  # exact ends


def test_rate_inverse_needs_a_monotone_sample_map() -> None:
    fast = RateDependentPI(0.1, [0.5, 1.0], [0.3, 0.2], 5e-4)  # beta/dt = 5: not monotone
    with pytest.raises(NotInvertibleError, match="not monotone"):
        fast.inverse()(_u(100), dt=DT)
    with pytest.raises(NotInvertibleError):
        RateDependentPI(0.1, [0.5, 1.0], [-0.3, 0.2], 1e-5).inverse()


def test_initial_memory_inverse_starts_in_the_consistent_state() -> None:
    m = InitialMemory(PIModel(1.0, [0.5, 1.0], [0.3, 0.2]), [2.0, -1.0])
    inv = m.inverse()
    # the inverse starts where the output of the same history leaves the inverse PI
    np.testing.assert_allclose(m(inv(_u(50))), _u(50), rtol=0, atol=1e-14)
    assert np.any(inv.state0 != 0)


@pytest.mark.parametrize("delay_s", [3e-4, 2.5e-4, 0.0])
def test_delay_inverse_is_an_advance_with_a_preview(delay_s) -> None:
    d = Delay(delay_s)
    inv = d.inverse()
    assert isinstance(inv, Advance)
    P = inv.preview_samples(DT)
    assert P == int(np.ceil(delay_s / DT - 1e-9))
    u = _u()
    e = np.abs(d(inv(u, dt=DT), dt=DT) - u)[P:-P or None]
    m, f = divmod(round(delay_s / DT, 9), 1)
    bound = f * (1 - f) * np.max(np.abs(np.diff(u, 2)))
    assert e.max() <= bound * (1 + 1e-9) + 1e-15
    # the causal form, fed the trajectory P samples ahead, gives the same drive P steps late
    form = causal_form(inv, DT)
    assert form.preview == P
    y_c = form.model(u, dt=DT)
    np.testing.assert_allclose(y_c[P:], inv(u, dt=DT)[: u.size - P], rtol=0, atol=1e-14)


def test_chain_preview_adds_up_and_drift_behind_an_advance_starts_early() -> None:
    plant = Chain.of(PI, Drift([0.5, 0.2], 2.0), Delay(2.5e-4), Lag(1e-3), Delay(1e-4))
    inv = plant.inverse()
    assert inv.preview_samples(DT) == 1 + 3
    form = causal_form(inv, DT)
    u = 30 + _u(amp=20.0)
    u[:20] = u[20]  # at rest at the start: the warm-up leaves the same hysteresis state
    y_nc = inv(u, dt=DT)
    y_c = form.model(u, dt=DT)
    P = form.preview
    np.testing.assert_allclose(y_c[P:], y_nc[: u.size - P], rtol=0, atol=1e-10)


def test_tf_memo_is_thread_safe_under_concurrent_requests() -> None:
    from core.stages import linear

    linear._tf_memo_key.cache_clear()
    errors: list[BaseException] = []
    results: list[np.ndarray] = []

    def work(k: int) -> None:
        try:
            for j in range(60):
                m = Creep([0.01 * (1 + (j + k) % 7), 0.1], [0.02, 0.01])
                results.append(m(_u(200), dt=DT * (1 + j % 5)))
        except BaseException as exc:  # pragma: no cover - the failure being tested
            errors.append(exc)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    assert len(results) == 240
    info = linear._tf_memo_key.cache_info()
    assert info.hits > 0 and info.currsize <= 4096
