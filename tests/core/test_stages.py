"""Effect models: analytic responses, state continuation, serialisation, validation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from core.base import Chain, model_from_dict
from core.exceptions import ParameterError
from core.operators import play_bank
from core.pi import PIModel
from core.stages import (
    Asymmetry,
    Creep,
    Delay,
    Drift,
    InitialMemory,
    Lag,
    Offset,
    RateDependentPI,
    Resonance,
    rd_play_bank,
)

DT = 1e-4
PI = PIModel(0.5, [10.0, 30.0, 60.0], [0.1, 0.08, 0.05])


def _u(n: int = 3000) -> np.ndarray:
    t = np.arange(n) * DT
    return 80 * np.sin(2 * np.pi * 7 * t) * np.exp(-t) + 10 * np.sin(2 * np.pi * 31 * t)


ALL = [
    Delay(3.7e-4),
    Lag(2e-3),
    Resonance(300.0, 0.05),
    Creep([0.01, 0.1, 1.0], [0.01, 0.01, 0.02]),
    Drift([0.3, -0.1], 0.2),
    Asymmetry([0.2, -0.05], 5.0, 40.0),
    Offset(-1.5),
]


@pytest.mark.parametrize("stage", ALL, ids=lambda m: m.type_name)
def test_chunked_simulation_equals_one_call(stage) -> None:
    model = PI >> stage
    u = _u()
    y = model(u, dt=DT)
    a = model.simulate(u[:1234], dt=DT)
    b = model.simulate(u[1234:], state=a.state, dt=DT)
    np.testing.assert_allclose(np.concatenate((a.y, b.y)), y, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    "model",
    [PI >> s for s in ALL]
    + [RateDependentPI(0.5, [10.0, 30.0], [0.1, 0.2], 2e-4), InitialMemory(PI, [-70.0, 20.0])],
    ids=lambda m: m.to_dict()["type"] if not isinstance(m, Chain) else m.stages[-1].type_name,
)
def test_json_round_trip_reproduces_output(model) -> None:
    d = json.loads(json.dumps(model.to_dict()))
    again = model_from_dict(d)
    u = _u(800)
    np.testing.assert_array_equal(again(u, dt=DT), model(u, dt=DT))


def test_integer_and_fractional_delay_of_a_ramp_are_exact_shifts() -> None:
    u = np.arange(50, dtype=float)  # ramp starting at rest (the buffer holds u[0] = 0)
    y = Delay(3 * DT)(u, dt=DT)
    np.testing.assert_allclose(y[3:], u[:-3])
    y = Delay(2.25 * DT)(u, dt=DT)  # linear interpolation is exact on a ramp
    np.testing.assert_allclose(y[3:], u[3:] - 2.25)


def test_lag_ramp_response_matches_continuous_solution() -> None:
    tau = 3e-3
    t = np.arange(400) * DT
    y = Lag(tau)(t.copy(), dt=DT)  # input u(t) = t, at rest at 0
    exact = t - tau * (1 - np.exp(-t / tau))
    np.testing.assert_allclose(y, exact, atol=1e-12)


def test_resonance_has_unit_dc_gain_and_q_at_natural_frequency() -> None:
    fn, z = 200.0, 0.05
    r = Resonance(fn, z)
    np.testing.assert_allclose(r(np.full(100, 2.5), dt=DT), 2.5)
    t = np.arange(int(1.0 / DT)) * DT
    y = r(np.sin(2 * np.pi * fn * t), dt=DT)
    amp = np.max(np.abs(y[-int(0.05 / DT):]))  # steady state after 1 s (decay time 16 ms)
    assert amp == pytest.approx(1 / (2 * z), rel=0.01)


def test_creep_keeps_moving_in_step_direction_about_log_linearly() -> None:
    taus = np.array([0.01, 0.1, 1.0, 10.0])
    c = 0.01
    cr = Creep(taus, np.full(4, c))
    dt = 1e-3
    u = np.concatenate(([0.0], np.ones(int(5.0 / dt))))
    y = cr(u, dt=dt)
    hold = y[1:]
    assert np.all(np.diff(hold) >= -1e-15)  # keeps creeping up after an upward step
    t = np.arange(1, hold.size + 1) * dt
    per_decade = np.interp(1.0, t, hold) - np.interp(0.1, t, hold)
    assert per_decade == pytest.approx(c, rel=0.35)  # ~ c per decade of time
    y_down = cr(-u, dt=dt)
    np.testing.assert_allclose(y_down, -y)  # sign-locked to the step


def test_drift_is_legendre_in_time_and_held_outside_span() -> None:
    d = Drift([1.0, 0.5], 2.0)
    t = np.array([0.0, 1.0, 2.0, 5.0])
    s = np.clip(2 * t / 2.0 - 1, -1, 1)
    expect = 1.0 * s + 0.5 * (1.5 * s**2 - 0.5)
    np.testing.assert_allclose(d.drift(t), expect)
    y = d(np.zeros(4), dt=1.0)
    np.testing.assert_allclose(y, expect)


def test_asymmetry_and_offset_formulas() -> None:
    a = Asymmetry([0.2, 0.1], 1.0, 2.0)
    x = np.array([-3.0, 1.0, 5.0])
    q = (x - 1.0) / 2.0
    np.testing.assert_allclose(a(x), x + 0.2 * q**2 + 0.1 * q**3)
    o = Offset(2.0)
    np.testing.assert_allclose(o.inverse()(o(x)), x)


def test_rate_dependent_pi_reduces_to_pi_and_widens_fast_loops() -> None:
    u = _u()
    rd0 = RateDependentPI(PI.p0, PI.thresholds, PI.weights, 0.0)
    np.testing.assert_allclose(rd0(u, dt=DT), PI(u), atol=1e-12)
    Y, _ = rd_play_bank(u, PI.thresholds, 0.0, DT)
    np.testing.assert_array_equal(Y, play_bank(u, PI.thresholds)[0])

    def width(f: float) -> float:
        t = np.arange(int(3 / f / DT)) * DT
        uu = 50 * np.sin(2 * np.pi * f * t)
        y = RateDependentPI(PI.p0, PI.thresholds, PI.weights, 2e-3)(uu, dt=DT)
        last = t >= 2 / f
        up = (np.abs(uu) < 2) & last & (np.gradient(uu) > 0)
        dn = (np.abs(uu) < 2) & last & (np.gradient(uu) < 0)
        return float(y[dn].mean() - y[up].mean())

    assert width(20.0) > width(1.0) > 0


def test_initial_memory_equals_running_the_history_first() -> None:
    hist = np.array([-90.0, 35.0, -5.0])
    u = _u(1500)
    im = InitialMemory(PI, hist)
    full = PI(np.concatenate((hist, u)))[hist.size :]
    np.testing.assert_allclose(im(u), full, atol=1e-12)
    assert np.allclose(im.inverse()(im(u)), u, atol=1e-9)


@pytest.mark.parametrize(
    "build, msg",
    [
        (lambda: Delay(-1e-3), "delay_s"),
        (lambda: Lag(0.0), "tau_s"),
        (lambda: Resonance(100.0, -0.1), "damping"),
        (lambda: Creep([1.0, 0.1], [0.1, 0.1]), "increasing"),
        (lambda: Creep([0.1, 1.0], [0.1, -0.1]), "negative"),
        (lambda: RateDependentPI(0.5, [1.0], [0.1], -1e-3), "beta_s"),
        (lambda: InitialMemory(Offset(1.0), [1.0]), "initial-memory"),
        (lambda: model_from_dict({"type": "lag"}), "tau_s"),
    ],
)
def test_invalid_parameters_name_the_problem(build, msg) -> None:
    with pytest.raises(ParameterError, match=msg):
        build()


def test_dynamic_effects_need_dt() -> None:
    with pytest.raises(ParameterError, match="dt"):
        (PI >> Lag(1e-3))(np.zeros(10))


def test_signed_gain_keeps_zero_and_inverts_exactly() -> None:
    from core.stages import SignedGain

    g = SignedGain(0.8, 1.6)
    x = np.linspace(-2.0, 2.0, 41)
    y = g(x)
    assert y[x == 0][0] == 0.0 and g.ratio == pytest.approx(2.0)
    assert np.allclose(y, np.where(x >= 0, 0.8 * x, 1.6 * x))
    assert np.max(np.abs(g.inverse()(y) - x)) < 1e-15
    for bad in ((0.0, 1.0), (1.0, -1.0)):
        with pytest.raises(ParameterError, match="must be > 0"):
            SignedGain(*bad)
