"""The Bouc-Wen bank (core.boucwen) against closed-form solutions of the law and against the
benchmark's separately written truth plant (benchmarks/diagnosis/families.py)."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.families import BASES, _bouc_wen_z, make_base
from core.base import model_from_dict
from core.boucwen import BoucWenModel, bouc_wen_states, saturation_levels
from core.exceptions import NotInvertibleError, ParameterError


def _path(nodes: list[float], per_unit: float) -> np.ndarray:
    parts = [np.array([nodes[0]])]
    for a, b in zip(nodes[:-1], nodes[1:], strict=True):
        k = max(1, round(abs(b - a) * per_unit))
        parts.append(np.linspace(a, b, k + 1)[1:])
    return np.concatenate(parts)


NODES = [0.0, 120.0, 30.0, 100.0, 50.0, 150.0, 10.0, 80.0, 60.0]


def test_n1_loading_and_unloading_match_the_closed_form() -> None:
    b, g = 0.03, 0.01
    u = np.linspace(0.0, 60.0, 13)  # 5-unit jumps, integrated in sub-steps
    Z, st = bouc_wen_states(u, [b], [g], [1.0], max_step=0.05)
    c = b + g
    np.testing.assert_allclose(Z[:, 0], (1 - np.exp(-c * u)) / c, rtol=1e-9, atol=1e-12)
    # unloading from z_r > 0: dz/du = 1 + (b - g) z, so z + 1/(b-g) grows as exp((b-g) du)
    zr, down = st.z[0], np.linspace(60.0, 50.0, 3)[1:]
    Z2, _ = bouc_wen_states(down, [b], [g], [1.0], z0=st.z, u0=st.u, max_step=0.05)
    d = b - g
    want = (zr + 1 / d) * np.exp(d * (down - 60.0)) - 1 / d
    np.testing.assert_allclose(Z2[:, 0], want, rtol=1e-9)


def test_n2_loading_is_a_tanh() -> None:
    b, g = 4e-4, -1e-4
    u = np.array([0.0, 10.0, 40.0, 100.0])  # one jump of 60 input units
    Z, _ = bouc_wen_states(u, [b], [g], [2.0], max_step=0.1)
    s = np.sqrt(b + g)
    np.testing.assert_allclose(Z[:, 0], np.tanh(s * u) / s, rtol=1e-9)
    assert np.all(Z <= saturation_levels([b], [g], [2.0])[0])


@pytest.mark.parametrize("name", ["bouc-wen-1", "bouc-wen-2", "bouc-wen-3"])
def test_bank_matches_the_benchmark_plant(name: str) -> None:
    p = BASES[name]()
    u = _path(NODES, 0.3)  # 3.3-unit moves: several sub-steps per sample
    want = _bouc_wen_z(u, 1.0, p.beta, p.gamma, p.n, 0.25, 0.0)
    Z, st = bouc_wen_states(u, [p.beta], [p.gamma], [p.n], max_step=0.25)
    np.testing.assert_allclose(Z[:, 0], want, rtol=0, atol=1e-12 * np.max(np.abs(want)))
    # a finer integration agrees to the integration error: the result has converged
    Zf, _ = bouc_wen_states(u, [p.beta], [p.gamma], [p.n], max_step=0.02)
    np.testing.assert_allclose(Zf[:, 0], want, atol=1e-6 * np.max(np.abs(want)))
    assert st.u == u[-1] and st.z[0] == Z[-1, 0]


def test_bank_columns_are_the_single_elements_and_chunks_continue() -> None:
    beta, gamma, n = [0.03, 4e-4, 0.004], [0.01, -1e-4, 0.002], [1.0, 2.0, 1.5]
    u = 75 - 75 * np.cos(np.linspace(0, 5 * np.pi, 700)) * np.linspace(1, 0.2, 700)
    Z, st = bouc_wen_states(u, beta, gamma, n, z0=[1.0, -2.0, 0.5], max_step=0.3, u0=10.0)
    for j in range(3):
        Zj, _ = bouc_wen_states(
            u,
            beta[j : j + 1],
            gamma[j : j + 1],
            n[j : j + 1],
            z0=[[1.0, -2.0, 0.5][j]],
            max_step=0.3,
            u0=10.0,
        )
        np.testing.assert_array_equal(Z[:, j], Zj[:, 0])
    Za, sa = bouc_wen_states(u[:333], beta, gamma, n, z0=[1.0, -2.0, 0.5], max_step=0.3, u0=10.0)
    Zb, sb = bouc_wen_states(u[333:], beta, gamma, n, z0=sa.z, u0=sa.u, max_step=0.3)
    np.testing.assert_array_equal(np.vstack([Za, Zb]), Z)
    np.testing.assert_array_equal(sb.z, st.z)


def test_bad_parameters_are_named() -> None:
    with pytest.raises(ParameterError, match="n\\[0\\] = 0.5 must be >= 1"):
        bouc_wen_states([0.0, 1.0], [0.1], [0.1], [0.5], max_step=0.1)
    with pytest.raises(ParameterError, match="max_step"):
        bouc_wen_states([0.0, 1.0], [0.1], [0.1], [1.0], max_step=0.0)


# ----------------------------------------------------------------------------- the model
def _family_model(name: str) -> tuple[object, BoucWenModel]:
    p = make_base(name)
    m = BoucWenModel.from_classical(p.gain * p.k, [-p.gain * p.c], [p.beta], [p.gamma], [p.n])
    return p, m


def _sine_and_staircase() -> np.ndarray:
    t = np.linspace(0.0, 3.0, 3000)
    sine = 75 - 75 * np.cos(2 * np.pi * t) * np.exp(-t / 2)
    stairs = np.repeat([30.0, 60.0, 90.0, 120.0, 150.0, 100.0, 20.0, 0.0], 40)
    return np.concatenate((sine, stairs))


@pytest.mark.parametrize("name", ["bouc-wen-1", "bouc-wen-2", "bouc-wen-3"])
def test_model_matches_the_benchmark_plant_and_inverts_it(name: str) -> None:
    plant, m = _family_model(name)
    u = _sine_and_staircase()
    y_true = plant(u)  # type: ignore[operator]
    # the model's own sub-steps (z_s / 16) and the plant's (0.25 V) agree to 1e-5 of 100 um
    np.testing.assert_allclose(m(u), y_true, rtol=0, atol=1e-3)
    x = m.inverse()(y_true)
    np.testing.assert_allclose(m(x), y_true, rtol=0, atol=1e-9 * np.ptp(y_true))
    np.testing.assert_allclose(x, u, rtol=0, atol=2e-3)  # the plant's input, to its 1e-3 um


def test_model_chunks_json_and_classical_parameters() -> None:
    m = BoucWenModel(
        1.0, [-0.25, 0.1], [0.5, 1.0], [1.5, 1.0], [1.0, 1.5], state0=[0.1, -0.2], input0=0.5
    )
    np.testing.assert_allclose(m.beta + m.gamma, m.saturation**-m.exponent)
    np.testing.assert_allclose(2 * m.beta / (m.beta + m.gamma), m.reversal_slope)
    back = BoucWenModel.from_classical(
        m.k, m.weights, m.beta, m.gamma, m.exponent, m.state0, m.input0
    )
    np.testing.assert_allclose(back.saturation, m.saturation)
    u = 2.5 * np.sin(np.linspace(0, 12, 900))
    y = m(u)
    np.testing.assert_array_equal(model_from_dict(m.to_dict())(u), y)
    r1 = m.simulate(u[:400])
    np.testing.assert_array_equal(np.r_[r1.y, m.simulate(u[400:], state=r1.state).y], y)
    inv = m.inverse()
    i1 = inv.simulate(y[:400])
    x = np.r_[i1.y, inv.simulate(y[400:], state=i1.state).y]
    np.testing.assert_allclose(x, u, atol=1e-9)
    # the states are the element variables the bank gives from the same start
    Z, _ = bouc_wen_states(
        u, m.beta, m.gamma, m.exponent, m.state0, max_step=m.substep, u0=m.input0, max_substeps=16
    )
    np.testing.assert_array_equal(m.states(u), Z)
    np.testing.assert_allclose(y, m.k * u + Z @ m.weights, rtol=0, atol=1e-13)


def test_model_rules_are_worded_for_users() -> None:
    ok = dict(k=1.0, weights=[-0.4], saturation=[25.0], reversal_slope=[1.5], exponent=[1.0])
    with pytest.raises(NotInvertibleError, match=r"smallest slope .* is -0.2; it must be > 0"):
        BoucWenModel(**{**ok, "weights": [-0.8]}).inverse()
    with pytest.raises(ParameterError, match=r"state0\[0\] = 30 lies outside .* ±25"):
        BoucWenModel(**ok, state0=[30.0])
    with pytest.raises(ParameterError, match=r"exponent\[0\] = 0.5 must be >= 1"):
        BoucWenModel(**{**ok, "exponent": [0.5]})
    with pytest.raises(ParameterError, match="saturation"):
        BoucWenModel(**{**ok, "saturation": [0.0]})
    with pytest.raises(ParameterError, match=r"beta >= 0 and beta \+ gamma > 0"):
        BoucWenModel.from_classical(1.0, [-0.4], [0.01], [-0.02], [1.0])


def test_jumps_beyond_the_substep_cap_stay_bounded_and_invert() -> None:
    """A jump of 2000 saturations in one sample takes at most MAX_SUBSTEPS sub-steps: the
    variables stay inside ±z_s (saturated, as the exact solution) and the inverse holds."""
    m = BoucWenModel(1.0, [-0.3], [0.5], [3.0], [2.5])
    u = np.array([0.0, 1000.0, -1000.0, 0.2, 0.1, 1000.0])
    Z = m.states(u)
    assert np.all(np.abs(Z) <= 0.5)
    np.testing.assert_allclose(Z[[1, 2, 5], 0], [0.5, -0.5, 0.5], rtol=1e-12)
    y = m(u)
    np.testing.assert_allclose(m(m.inverse()(y)), y, rtol=0, atol=1e-9 * np.ptp(y))
