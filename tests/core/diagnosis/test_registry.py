"""The registry of diagnosable effects (issue 17): each effect declares itself once, and a
new effect is one registration, with nothing else in the engine, the structure fit, the
saved model or the C export to change."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from benchmarks.diagnosis.generator import truth_pi
from core.base import Model
from core.diagnosis import Structure, diagnose
from core.diagnosis.candidates import scalar_search, sigma_from_curvature
from core.diagnosis.registry import EFFECTS, DiagnosableEffect, OutputDynamics, effect
from core.export_c import generate_c
from core.lti import LinearSystem
from core.recordings import Recording

FIELDS = {f.name for f in dataclasses.fields(Structure)}


def test_every_effect_declares_what_the_engine_reads() -> None:
    assert list(EFFECTS) == ["delay", "lag", "resonance", "rate", "creep", "drift", "asymmetry",
                             "offset", "initial-memory", "saturation", "dead-zone"]
    for name, e in EFFECTS.items():
        assert e.name == name
        assert e.structure_field is None or e.structure_field in FIELDS, name
        assert issubclass(e.model_type, Model) and e.model_type.type_name, name
        assert e.explanation and e.equation and callable(e.build)
        assert all(other in EFFECTS for other in e.lookalikes)
        if e.mimicked_by is not None:
            assert e.mimicked_by[0] <= set(EFFECTS)
    # loop shapes are part of the hysteresis: they have no field to switch off
    assert {n for n, e in EFFECTS.items() if e.structure_field is None} == {
        "saturation", "dead-zone"}
    with pytest.raises(KeyError, match="known: delay, lag"):
        effect("backlash")


@pytest.mark.parametrize("name, values", [("delay", (1e-3,)), ("lag", (2e-3,)),
                                          ("resonance", (300.0, 0.1))])
def test_dynamics_stages_are_their_model(name: str, values: tuple[float, ...]) -> None:
    """The stage a structure adds is the effect's model, and its transfer function has unit
    static gain (the PI sets the gain)."""
    e = EFFECTS[name]
    m = e.dynamics.model(values)
    assert isinstance(m, e.model_type)
    assert [getattr(m, k) for k in e.dynamics.params] == list(values)
    if e.dynamics.transfer is not None:
        num, den = e.dynamics.transfer(values)
        assert num[-1] / den[-1] == pytest.approx(1.0)


# ------------------------------------------------------------------ a new effect, one module
def _lead_lag(tau: float) -> LinearSystem:
    """A lag with a zero at twice its corner: ``(tau/2 s + 1) / (tau s + 1)``."""
    return LinearSystem([tau / 2, 1.0], [tau, 1.0])


def _build_lead_lag(ctx, cur):
    s = cur.structure
    if s.dynamics:
        return None
    grid = np.geomspace(1e-3, 0.1, 12)
    best, fit, info = scalar_search(ctx, lambda v: s.with_(dynamics=("lead-lag", v)), grid, cur)
    return fit, {"tau_s": best}, {"tau_s": sigma_from_curvature(
        ctx, fit, info["profile_curvature"], best)}


LEAD_LAG = DiagnosableEffect(
    "lead-lag", "dynamics",
    explanation="A sensor conditioning network with a lag and a zero at twice its corner.",
    equation="y = (tau/2 s + 1) / (tau s + 1) y_PI",
    build=_build_lead_lag, model_type=LinearSystem, structure_field="dynamics",
    time_dependent=True,
    dynamics=OutputDynamics(("tau_s",), model=lambda v: _lead_lag(v[0]),
                            transfer=lambda v: ([v[0] / 2, 1.0], [v[0], 1.0])))


def test_a_registered_effect_is_found_modelled_and_exported(monkeypatch) -> None:
    monkeypatch.setitem(EFFECTS, "lead-lag", LEAD_LAG)
    rng = np.random.default_rng(5)
    plant = truth_pi() >> _lead_lag(0.01)
    recs = []
    for k in range(2):
        t = np.arange(0, 1.5, 1e-4)
        u = 5 + 2.5 * np.sin(2 * np.pi * 20 * t + k) + 2.0 * np.sin(2 * np.pi * 35 * t + 2 * k)
        rest = np.full(5000, u[0])  # the stage in its steady state when the record starts
        y = plant.simulate(np.r_[rest, u], dt=1e-4).y[rest.size:]
        recs.append(Recording(t, u, y + 0.002 * float(np.ptp(y)) * rng.standard_normal(y.size),
                              f"run {k}"))
    res = diagnose(recs, effects=["lead-lag"])
    assert [f.name for f in res.effects] == ["lead-lag"]
    assert res.effects[0].parameters["tau_s"] == pytest.approx(0.01, rel=0.05)
    assert "lead-lag" in res.summary()
    model = res.model
    assert any(isinstance(m, LinearSystem) for m in model.stages)
    pred = model.simulate(recs[0].u, dt=1e-4).y
    late = slice(2000, None)  # the saved stage starts at rest: after 20 time constants
    assert np.sqrt(np.mean((pred - recs[0].y)[late] ** 2)) < 0.005 * np.ptp(recs[0].y)
    assert "double" in generate_c(model, dt=1e-4).source
