"""LinearSystem: exact ZOH against analytic responses and scipy, state carrying, eq. 38."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal as ss

from core.base import Chain, model_from_dict
from core.exceptions import NotInvertibleError, ParameterError
from core.lti import InverseLinearSystem, LinearSystem

# paper 001 eq. (38)
G38 = ([8.8e16], [1.0, 1.6e4, 6.6e8, 5.3e12, 8.8e16])


def test_first_order_step_is_exact() -> None:
    tau, dt = 0.01, 1e-3
    g = LinearSystem([2.0], [tau, 1.0])
    y = g(np.ones(50), dt=dt)
    k = np.arange(50)
    assert np.allclose(y, 2.0 * (1.0 - np.exp(-k * dt / tau)), rtol=0, atol=1e-14)


def test_second_order_matches_scipy_zoh_and_lsim() -> None:
    wn, zeta, dt = 2 * np.pi * 50.0, 0.1, 1e-4
    num, den = [wn**2], [1.0, 2 * zeta * wn, wn**2]
    g = LinearSystem(num, den)
    rng = np.random.default_rng(0)
    u = rng.standard_normal(3000)
    y = g(u, dt=dt)
    _, yref, _ = ss.lsim((num, den), u, np.arange(u.size) * dt, interp=False)
    assert np.max(np.abs(y - yref)) < 1e-10 * np.max(np.abs(yref))
    numd, dend, _ = ss.cont2discrete((num, den), dt, method="zoh")
    assert np.max(np.abs(y - ss.lfilter(numd.ravel(), dend, u))) < 1e-9


def test_eq38_discrete_poles_dc_gain_and_step() -> None:
    g = LinearSystem(*G38)
    assert g.dc_gain == pytest.approx(1.0)
    assert g.is_stable and g.order == 4 and g.is_strictly_proper
    # the poles are near 2.5 and 3.1 kHz (paper: "near 4 kHz")
    f = np.sort(np.abs(g.poles)) / (2 * np.pi)
    assert np.allclose(f, [2458.3, 2458.3, 3056.7, 3056.7], rtol=1e-4)
    for dt in (1e-5, 2e-5, 1e-4):
        Ad, _, _, _ = g.discretize(dt)
        ev = np.sort_complex(np.linalg.eigvals(Ad))
        ex = np.sort_complex(np.exp(g.poles * dt))
        assert np.max(np.abs(ev - ex)) < 1e-12  # exact ZOH: z = exp(p dt)
    dt = 2e-5
    y = g(np.ones(5000), dt=dt)
    assert y[-1] == pytest.approx(1.0, abs=1e-9)
    _, yref, _ = ss.lsim(G38, np.ones(5000), np.arange(5000) * dt, interp=False)
    assert np.max(np.abs(y - yref)) < 1e-9


def test_sine_steady_state_matches_frequency_response() -> None:
    g = LinearSystem(*G38)
    fs, f = 50_000.0, 1000.0
    t = np.arange(int(0.02 * fs)) / fs
    y = g(np.sin(2 * np.pi * f * t), dt=1 / fs)
    H = g.frequency_response(f)
    tail = t > 0.01
    ref = np.abs(H) * np.sin(2 * np.pi * f * t + np.angle(H))
    # ZOH adds a half-sample delay: compare with the response of the held input, phase
    # shifted by -π f dt
    ref_zoh = np.abs(H) * np.sin(2 * np.pi * f * (t - 0.5 / fs) + np.angle(H))
    assert np.max(np.abs(y[tail] - ref_zoh[tail])) < 2e-3
    assert np.max(np.abs(y[tail] - ref[tail])) < 0.1


def test_chunked_equals_one_call_and_state_is_dt_independent() -> None:
    g = LinearSystem([1.0, 3.0], [1.0, 2.0, 10.0])
    u = np.random.default_rng(1).standard_normal(400)
    one = g.simulate(u, dt=1e-2)
    a = g.simulate(u[:123], dt=1e-2)
    b = g.simulate(u[123:], state=a.state, dt=1e-2)
    assert np.array_equal(np.concatenate((a.y, b.y)), one.y)
    assert np.array_equal(b.state, one.state)
    # halving dt with the input held for two samples gives the same state at even samples
    half = g.simulate(np.repeat(u, 2), dt=5e-3)
    assert np.allclose(half.y[::2], one.y, rtol=0, atol=1e-12)
    assert np.allclose(half.state, one.state, rtol=0, atol=1e-12)


def test_rest_state_is_equilibrium() -> None:
    g = LinearSystem(*G38)
    x0 = g.rest_state(3.0)
    y = LinearSystem(*G38, state0=x0)(np.full(100, 3.0), dt=2e-5)
    assert np.allclose(y, 3.0, atol=1e-9)
    with pytest.raises(ParameterError, match="pole at s = 0"):
        LinearSystem([1.0], [1.0, 0.0]).rest_state(1.0)


def test_static_gain_and_biproper_inverse() -> None:
    k = LinearSystem([3.0], [2.0])
    assert k.order == 0
    assert np.array_equal(k(np.array([1.0, -2.0]), dt=0.1), [1.5, -3.0])
    lead = LinearSystem([1.0, 2.0], [1.0, 20.0])
    u = np.random.default_rng(2).standard_normal(300)
    for dt in (1e-3, 1e-2):
        round_trip = (lead >> lead.inverse())(u, dt=dt)
        assert np.allclose(round_trip, u, rtol=0, atol=1e-12)
        assert np.allclose((lead.inverse() >> lead)(u, dt=dt), u, rtol=0, atol=1e-12)
    assert lead.inverse().inverse() is lead
    d = lead.inverse().to_dict()
    assert isinstance(model_from_dict(d), InverseLinearSystem)


def test_not_invertible_and_invalid() -> None:
    with pytest.raises(NotInvertibleError, match="strictly proper \\(relative degree 4"):
        LinearSystem(*G38).inverse()
    with pytest.raises(NotInvertibleError, match="zero at s = 1 with Re >= 0"):
        LinearSystem([1.0, -1.0], [1.0, 1.0]).inverse()
    with pytest.raises(ParameterError, match="improper"):
        LinearSystem([1.0, 0.0, 0.0], [1.0, 1.0])
    with pytest.raises(ParameterError, match="the denominator a must have a nonzero coefficient"):
        LinearSystem([1.0], [0.0, 0.0])
    with pytest.raises(ParameterError, match="num\\[0\\] = nan is not finite"):
        LinearSystem([np.nan], [1.0, 1.0])
    with pytest.raises(ParameterError, match="den must have at least 1"):
        LinearSystem([1.0], [])
    with pytest.raises(ParameterError, match="state0 must have length 2"):
        LinearSystem([1.0], [1.0, 1.0, 1.0], state0=[0.0])
    with pytest.raises(ParameterError, match="needs the sample spacing dt > 0"):
        LinearSystem([1.0], [1.0, 1.0])(np.ones(3))


def test_serialisation_and_zpk() -> None:
    g = LinearSystem(*G38, state0=[0.1, 0.0, 0.0, 0.0])
    g2 = model_from_dict(g.to_dict())
    u = np.sin(np.linspace(0, 10, 500))
    assert np.array_equal(g(u, dt=2e-5), g2(u, dt=2e-5))
    z = LinearSystem.from_zpk([], [-1.0 + 2j, -1.0 - 2j], 5.0)
    assert np.allclose(z.den, [1.0, 2.0, 5.0]) and z.dc_gain == pytest.approx(1.0)
    with pytest.raises(ParameterError, match="poles must come in complex-conjugate pairs"):
        LinearSystem.from_zpk([], [-1.0 + 2j], 1.0)
    assert Chain.of(g, g).needs_dt


def test_eighth_order_butterworth_coefficients_spanning_1e34() -> None:
    """Frequency scaling + balancing keep a badly scaled high-order system exact.

    The denominator of an 8th-order 3 kHz Butterworth runs from 1 to 1.6e34; the plain
    companion realization discretised with expm misplaces the poles by ~4e-4 and the DC
    gain by ~2e-7 (measured), the scaled and balanced one by < 1e-12.
    """
    b, a = ss.butter(8, 2 * np.pi * 3000.0, analog=True)
    g = LinearSystem(b, a)
    dt = 1e-5
    Ad, _, _, _ = g.discretize(dt)
    ev = np.sort_complex(np.linalg.eigvals(Ad))
    ex = np.sort_complex(np.exp(g.poles * dt))
    assert np.max(np.abs(ev - ex)) < 1e-12
    assert g(np.ones(20000), dt=dt)[-1] == pytest.approx(1.0, abs=1e-12)
    # Butterworth: |G(j w_c)| = 1/sqrt(2) at the corner frequency
    assert abs(g.frequency_response(3000.0)) == pytest.approx(2**-0.5, rel=1e-9)
