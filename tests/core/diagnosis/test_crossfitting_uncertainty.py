"""Parameter uncertainties that say when the recordings disagree (issue 16): each effect is
fitted on every recording alone, the estimates' Birge ratio widens the sigma, and a
parameter whose sigma stays beyond a quarter (the resonance frequency: a tenth) of its value
is reported as ambiguous rather than as a number."""

from __future__ import annotations

import numpy as np
import pytest

import core.diagnosis.engine as engine
from benchmarks.diagnosis.generator import truth_pi
from core.diagnosis import diagnose
from core.diagnosis.crossfitting import ambiguous_parameters, combine_uncertainty
from core.recordings import Recording
from core.stages import Delay


def test_ambiguous_thresholds() -> None:
    """A quarter of the value, a tenth for the resonance frequency; non-numbers ignored."""
    assert ambiguous_parameters({"delay_s": 1e-3}, {"delay_s": 0.3e-3}) == ["delay_s"]
    assert ambiguous_parameters({"delay_s": 1e-3}, {"delay_s": 0.2e-3}) == []
    assert ambiguous_parameters({"freq_hz": 200.0, "damping": 0.05},
                                {"freq_hz": 25.0, "damping": 0.01}) == ["freq_hz"]
    assert ambiguous_parameters({"weights": [0.1]}, {"weights": [1.0]}) == []
    assert ambiguous_parameters({"tau_s": 1e-3}, {"tau_s": None}) == []


def test_combine_takes_the_larger_sigma() -> None:
    sp = {"sigma_between": {"delay_s": 4e-4}}
    assert combine_uncertainty({"delay_s": 1e-6}, sp) == {"delay_s": 4e-4}
    assert combine_uncertainty({"delay_s": 1e-3}, sp) == {"delay_s": 1e-3}
    assert combine_uncertainty({"tau_s": None}, {"sigma_between": {"tau_s": 2.0}}) == {
        "tau_s": 2.0}
    assert combine_uncertainty({"delay_s": 1e-6}, None) == {"delay_s": 1e-6}


def _recordings(delays: tuple[float, ...], seed: int = 3) -> list[Recording]:
    """The benchmark's PI followed by a transport delay that differs per recording (s); the
    same two-tone input shape in each, 0.2 % white noise."""
    rng = np.random.default_rng(seed)
    pi = truth_pi()
    out = []
    for k, d in enumerate(delays):
        t = np.arange(0, 1.5, 1e-4)
        u = 5 + 2.5 * np.sin(2 * np.pi * 7 * t + k) + 2.0 * np.sin(2 * np.pi * 11 * t + 2 * k)
        y = (pi >> Delay(d)).simulate(u, dt=1e-4).y
        out.append(Recording(t, u, y + 0.002 * float(np.ptp(y)) * rng.standard_normal(y.size),
                             f"run {k}"))
    return out


@pytest.fixture(scope="module")
def discordant() -> list[Recording]:
    return _recordings((0.5e-3, 1e-3, 2e-3))


def test_recordings_that_disagree_make_the_delay_ambiguous(discordant) -> None:
    res = diagnose(discordant)
    (f,) = [e for e in res.effects if e.name == "delay"]
    per = [p["delay_s"] for p in f.recording_spread["per_recording"]]
    assert per == pytest.approx([0.5e-3, 1e-3, 2e-3], rel=0.1)  # each recording alone
    assert f.recording_spread["birge_ratio"]["delay_s"] > 10
    assert f.uncertainty["delay_s"] > 0.25 * f.parameters["delay_s"]
    assert f.ambiguous_parameters == ["delay_s"]
    assert "Birge ratio" in f.uncertainty_method
    assert "delay_s ambiguous (estimate" in res.summary()
    assert res.to_dict()["effects"][0]["ambiguous_parameters"] == ["delay_s"]


def test_without_the_spread_the_delay_is_a_confident_number(discordant, monkeypatch) -> None:
    """The rule is what flags it: the noise-driven sigma alone is far below the spread."""
    monkeypatch.setattr(engine, "spread_over_recordings", lambda *a: None)
    res = diagnose(discordant)
    (f,) = [e for e in res.effects if e.name == "delay"]
    assert f.ambiguous_parameters == [] and f.recording_spread is None
    assert f.uncertainty["delay_s"] < 0.25 * f.parameters["delay_s"]


def test_recordings_that_agree_keep_the_number() -> None:
    res = diagnose(_recordings((1e-3, 1e-3)))
    found = [e for e in res.effects if e.name in ("delay", "lag", "resonance")]
    assert found, [e.name for e in res.effects]
    f = found[0]
    assert f.recording_spread is not None
    assert f.ambiguous_parameters == []
