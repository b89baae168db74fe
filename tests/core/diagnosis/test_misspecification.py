"""The base model's misspecification in the reported uncertainty (issue 16): an accepted
effect's parameters refitted on the other base families, the largest shift added to the
sigma, so that a seeded non-PI plant's truth lies within the reported 1-sigma or the
parameter is said ambiguous."""

from __future__ import annotations

import numpy as np
import pytest

import core.diagnosis.engine as engine
from benchmarks.diagnosis.families import make_family, parameter_recovery
from core.diagnosis import diagnose
from core.diagnosis.context import FitContext
from core.diagnosis.misspecification import _newton_steps, alternative_bases
from core.diagnosis.structure import Structure


def test_newton_steps_find_a_quadratic_minimum() -> None:
    """On an exact quadratic the first Newton step lands on the minimum (analytic)."""
    a = np.array([0.12, -0.07])
    A = np.array([[3.0, 1.0], [1.0, 2.0]])
    x = _newton_steps(lambda x: float((x - a) @ A @ (x - a)), np.zeros(2),
                      -np.ones(2), np.ones(2))
    assert x == pytest.approx(a, abs=1e-9)


def test_newton_steps_go_to_the_box_edge_without_a_minimum() -> None:
    """A profile without a minimum (concave) does not fix the parameter: the step goes to
    the box edge downhill, so the shift is as large as the search allows."""
    x = _newton_steps(lambda x: -float((x[0] - 0.1) ** 2), np.zeros(1), np.array([-0.5]),
                      np.array([0.5]))
    assert x == pytest.approx([-0.5])


def test_alternative_bases_are_the_other_families() -> None:
    t = np.arange(0, 1.0, 1e-3)
    u = 5 + 4 * np.sin(2 * np.pi * 3 * t)
    from core.recordings import Recording

    recs = [Recording(t, u, u.copy(), "r")]
    ctx = FitContext(recs, [np.ones(t.size, bool)], [np.zeros(t.size, bool)])
    s = Structure((0.5, 1.0, 2.0), ((),), dynamics=("delay", 1e-3))
    alts = dict(alternative_bases(ctx, s))
    assert list(alts) == ["preisach", "bouc-wen", "shifted"]
    assert all(a.dynamics == s.dynamics for a in alts.values())
    assert alts["shifted"].thresholds == pytest.approx((0.25, 0.75, 1.5))  # half a step down
    knots = dict(alternative_bases(ctx, s.with_(levels=(3.0, 6.0))))["shifted"].levels
    lo = float(u.min())
    assert knots == pytest.approx((lo + 0.5 * (3.0 - lo), 4.5))  # the level knots too
    # rate-dependent plays are not modelled on a Bouc-Wen bank; no Preisach of free weights
    assert [k for k, _ in alternative_bases(ctx, s.with_(beta_s=1e-4))] == ["preisach",
                                                                            "shifted"]
    assert [k for k, _ in alternative_bases(ctx, s.with_(free_weights=True))] == [
        "bouc-wen", "shifted"]


def _recovery(res, sc) -> list[dict]:
    return parameter_recovery(
        [{"name": e.name, "parameters": e.parameters, "uncertainty": e.uncertainty,
          "ambiguous_parameters": e.ambiguous_parameters} for e in res.effects],
        sc.extras["hidden"])


@pytest.fixture(scope="module")
def maxwell_resonance():
    """A Maxwell-slip plant (no base the diagnosis fits is it) with a 200 Hz mode."""
    return make_family("maxwell-slip", "resonance", "large", 0.002, 500)


def test_non_pi_resonance_is_honest(maxwell_resonance) -> None:
    res = diagnose(maxwell_resonance.records)
    rows = _recovery(res, maxwell_resonance)
    assert {q["quantity"] for q in rows} == {"freq_hz", "damping"}
    assert all(q["honest"] for q in rows), rows
    (f,) = [e for e in res.effects if e.name == "resonance"]
    # weights of either sign (a slip loop): no Preisach alternative
    assert set(f.base_sensitivity["per_base"]) == {"bouc-wen", "shifted"}
    assert "base model replaced by" in f.uncertainty_method


def test_without_the_base_term_the_resonance_is_over_confident(maxwell_resonance,
                                                               monkeypatch) -> None:
    """The rule is what makes it honest: without it the truth is several sigmas away and
    nothing is said ambiguous (same estimates)."""
    monkeypatch.setattr(engine, "_widen_for_base", lambda *a: None)
    res = diagnose(maxwell_resonance.records)
    rows = _recovery(res, maxwell_resonance)
    assert rows and not any(q["honest"] for q in rows), rows


def test_report_says_when_the_base_model_sets_the_parameter() -> None:
    """An ambiguous parameter whose sigma is mostly the base term gets its estimates on the
    other bases; one whose sigma is mostly statistical does not."""
    from types import SimpleNamespace

    from core.diagnosis.report import _base_dependence

    bs = {"base": "pi", "per_base": {"preisach": {"tau_s": 6e-3}, "shifted": {"tau_s": 4.6e-3}},
          "sigma": {"tau_s": 2.3e-3}, "sigma_statistical": {"tau_s": 0.6e-3}}
    e = SimpleNamespace(name="lag", parameters={"tau_s": 3.7e-3}, ambiguous_parameters=["tau_s"],
                        base_sensitivity=bs)
    (line,) = _base_dependence(e)
    assert "tau_s depends on the base model" in line
    assert "on a Preisach base" in line and "PI with its grid shifted half a step" in line
    e.base_sensitivity = dict(bs, sigma_statistical={"tau_s": 5e-3})
    assert _base_dependence(e) == []
    e.base_sensitivity, e.ambiguous_parameters = bs, []
    assert _base_dependence(e) == []
