"""Input signal generators: shapes, units, analytic values, validation and the registry."""

from __future__ import annotations

import json

import numpy as np
import pytest

from core.exceptions import ParameterError
from core.signals import (
    SIGNALS,
    build_signal,
    chirp,
    decaying_sine,
    list_signals,
    multisine,
    random_reversals,
    sine,
    staircase,
    time_vector,
    triangle,
)


def test_time_vector_includes_end_point() -> None:
    t = time_vector(2.0, 100.0)
    assert t.size == 201
    assert t[0] == 0.0 and t[-1] == pytest.approx(2.0)
    assert np.allclose(np.diff(t), 0.01)


def test_sine_values_match_formula() -> None:
    t, u = sine(amplitude=4.0, frequency=2.0, offset=1.0, duration=1.0, sample_rate=400.0)
    assert np.allclose(u, 1.0 + 4.0 * np.sin(4 * np.pi * t), atol=1e-15, rtol=0)
    assert u[t.searchsorted(0.125)] == pytest.approx(5.0)  # quarter period of 2 Hz


def test_multisine_is_example3_by_default() -> None:
    t, u = multisine(duration=1.0, sample_rate=1000.0)
    ref = 5.85 * np.sin(2 * np.pi * t) + 2.35 * np.sin(10 * np.pi * t)
    assert np.allclose(u, ref, atol=1e-14, rtol=0)


def test_decaying_sine_envelope_decays() -> None:
    t, u = decaying_sine(amplitude=4.0, frequency=1.0, decay_time=1.0, duration=5.0,
                         sample_rate=1000.0)
    assert np.all(np.abs(u) <= 4.0 * np.exp(-t) + 1e-12)
    # the peaks at t = 1/4 + k form a decreasing sequence: nested minor loops
    peaks = u[[250, 1250, 2250, 3250]]
    assert np.all(np.diff(peaks) < 0)
    assert peaks[1] / peaks[0] == pytest.approx(np.exp(-1.0), rel=1e-12)


def test_triangle_is_piecewise_linear_with_turning_points() -> None:
    t, u = triangle(amplitude=2.0, frequency=1.0, duration=2.0, sample_rate=1000.0)
    assert u[0] == pytest.approx(0.0)
    assert u[250] == pytest.approx(2.0) and u[750] == pytest.approx(-2.0)
    slope = np.diff(u) * 1000.0
    assert np.allclose(np.abs(slope), 8.0, rtol=1e-9)  # 4 A f
    assert np.sum(np.diff(np.sign(slope)) != 0) == 4  # reversals at 0.25, 0.75, 1.25, 1.75


def test_staircase_levels_and_holds() -> None:
    t, u = staircase(amplitude=1.0, steps=4, hold=0.01, sample_rate=1000.0, up_down=True)
    levels = u[::10]
    expected = np.concatenate((np.linspace(0, 1, 5), np.linspace(1, -1, 9)[1:],
                               np.linspace(-1, 1, 9)[1:]))
    assert np.allclose(levels, expected, atol=1e-15)
    assert t.size == u.size == expected.size * 10
    assert np.all(u.reshape(-1, 10) == u.reshape(-1, 10)[:, :1])  # held constant
    _, up_only = staircase(amplitude=1.0, steps=4, hold=0.01, sample_rate=1000.0, up_down=False)
    assert up_only.max() == 1.0 and up_only.min() == 0.0


def test_chirp_instantaneous_frequency() -> None:
    t, u = chirp(amplitude=1.0, f0=1.0, f1=21.0, duration=2.0, sample_rate=20000.0)
    # zero crossings of sin(phase) are where phase = kπ; count them per interval
    crossings = t[1:][np.diff(np.signbit(u)) != 0]
    # expected number of half-cycles: phase(T)/π = 2 (f0 T + (f1-f0) T / 2) = 2 * 22
    assert abs(crossings.size - 44) <= 1


def test_random_reversals_reproducible_and_bounded() -> None:
    t1, u1 = random_reversals(amplitude=3.0, reversals=15, duration=1.0, seed=7)
    _, u2 = random_reversals(amplitude=3.0, reversals=15, duration=1.0, seed=7)
    _, u3 = random_reversals(amplitude=3.0, reversals=15, duration=1.0, seed=8)
    assert np.array_equal(u1, u2) and not np.array_equal(u1, u3)
    assert np.max(np.abs(u1)) <= 3.0
    d = np.sign(np.diff(u1))
    d = d[d != 0]
    assert np.sum(d[1:] != d[:-1]) == 15  # exactly one direction change per turning point


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: sine(frequency=0.0), "frequency = 0 Hz must be > 0"),
        (lambda: sine(duration=-1.0), "duration = -1 s must be > 0"),
        (lambda: sine(sample_rate=np.nan), "sample_rate = nan is not finite"),
        (lambda: sine(frequency=600.0, sample_rate=1000.0), "Nyquist"),
        (lambda: sine(amplitude=-1.0), "amplitude = -1 must be >= 0"),
        (lambda: multisine([1.0, -1.0], [1.0, 2.0]), "amplitudes\\[1\\] = -1 must be >= 0"),
        (lambda: multisine([1.0, 2.0], [1.0]), "amplitudes has 2 entries but frequencies has 1"),
        (lambda: multisine([], []), "at least one component"),
        (lambda: staircase(steps=0), "steps = 0 must be >= 1"),
        (lambda: staircase(steps=2.5), "steps = 2.5 must be an integer"),
        (lambda: staircase(hold=1e-5, sample_rate=1000.0), "hold = 1e-05 s is shorter"),
        (lambda: chirp(f1=900.0, sample_rate=1000.0), "f1 = 900 Hz must be below"),
        (lambda: random_reversals(reversals=0), "reversals = 0 must be >= 1"),
        (lambda: sine(duration=1e6, sample_rate=1e6), "exceeds the limit"),
        (lambda: triangle(offset="x"), "offset must be a number"),
    ],
)
def test_invalid_parameters_name_the_parameter(call, match: str) -> None:
    with pytest.raises(ParameterError, match=match):
        call()


def test_registry_builds_every_signal_with_defaults() -> None:
    assert [s.name for s in list_signals()] == list(SIGNALS)
    for spec in list_signals():
        t, u = spec.build()
        assert t.shape == u.shape and t.ndim == 1 and t.size > 1
        assert np.all(np.isfinite(u))
        d = spec.to_dict()
        assert d["name"] == spec.name and {p["name"] for p in d["params"]} == set(
            spec.defaults()
        )
        for p in spec.params:  # the defaults lie inside the advertised ranges
            assert p.minimum <= float(p.default) <= p.maximum


def test_registry_description_is_json() -> None:
    doc = json.loads(json.dumps([s.to_dict() for s in list_signals()]))
    sine_spec = next(d for d in doc if d["name"] == "sine")
    amp = next(p for p in sine_spec["params"] if p["name"] == "amplitude")
    assert amp == {"name": "amplitude", "default": 4.0, "min": 0.0, "max": 1e6,
                   "unit": "input", "kind": "float", "description": "peak amplitude"}


def test_registry_converts_strings_and_checks_ranges() -> None:
    t, u = build_signal("sine", amplitude="2", frequency="1", duration="1", sample_rate="100")
    assert u.max() == pytest.approx(2.0)
    _, s = build_signal("staircase", steps="3", hold="0.01", up_down="false")
    assert s.max() == pytest.approx(4.0) and s.min() == 0.0
    with pytest.raises(ParameterError, match="unknown signal 'square'; valid signals: sine"):
        build_signal("square")
    with pytest.raises(ParameterError, match="has no parameter\\(s\\) freq; valid: amplitude"):
        build_signal("sine", freq=3)
    with pytest.raises(ParameterError, match="steps = 0 is outside the allowed range"):
        build_signal("staircase", steps=0)
    with pytest.raises(ParameterError, match="up_down must be true or false"):
        build_signal("staircase", up_down="maybe")
