"""``core.fitting.fit_recordings``: one keyword set for every estimator, typed outcome."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from core.exceptions import ParameterError, UnsupportedOptionError
from core.fitting import EmptyWindowError, FitOutcome, PIRegressor, TimeWindow, fit_recordings
from core.models import estimator_class, fit_kinds
from core.pi import PIModel
from core.recordings import Recording

TRUTH = PIModel(0.5, [0.4, 0.8, 1.2], [0.3, 0.2, 0.1])


def _rec(name: str = "r", amp: float = 2.0) -> Recording:
    t = np.linspace(0.0, 3.0, 3000)
    u = amp * np.sin(2 * np.pi * t) * np.exp(-t / 2.0)
    return Recording(t, u, TRUTH(u) + 1.0, name, units={"input": "V", "output": "um"})


@pytest.mark.parametrize("kind", fit_kinds())
def test_every_estimator_takes_the_same_keywords(kind):
    cls = estimator_class(kind)
    est = cls(n_operators=3, constraint="nonnegative", initial_memory="keep")
    assert (est.n_operators, est.constraint, est.initial_memory) == (3, "nonnegative", "keep")
    assert "keep" in cls.initial_memory_rules
    if "exclude" not in cls.initial_memory_rules:
        with pytest.raises(UnsupportedOptionError, match="initial_memory='exclude'"):
            cls(n_operators=3, initial_memory="exclude").fit(_rec().u, _rec().y)
    with pytest.raises(ParameterError, match="'exclude' or 'keep'"):
        cls(n_operators=3, initial_memory="forget").fit(_rec().u, _rec().y)


def test_outcome_matches_the_estimator_and_its_document():
    rec = _rec()
    out = fit_recordings(rec, n_operators=3, initial_memory="keep")
    assert isinstance(out, FitOutcome) and out.kind == "pi"
    with pytest.raises(dataclasses.FrozenInstanceError):
        out.kind = "mpi"  # type: ignore[misc]
    est = PIRegressor(n_operators=3).fit(rec.u, rec.y)  # a second, direct fit
    np.testing.assert_allclose(out.model(rec.u), est.full_model_(rec.u), rtol=0, atol=1e-12)
    assert out.report.test.rmse == pytest.approx(est.report_.test.rmse, rel=1e-12)
    doc = out.parameter_set.to_dict()
    fit = doc["provenance"]["fit"]
    assert fit["model"] == "pi" and fit["recordings"] == ["r"] and fit["files"] == ["r"]
    assert fit["n_operators"] == 3 and fit["train"] is None
    # three plays cannot follow this plant: the only warning is the misfit one (5x the floor)
    assert fit["warnings"] == list(out.warnings) == list(out.report.warnings)
    assert len(fit["warnings"]) == 1 and "white-noise floor" in fit["warnings"][0]
    assert doc["units"] == {"input": "V", "output": "um", "time": "s"}
    assert fit["report"]["train"]["rmse"] == pytest.approx(est.report_.train.rmse, rel=1e-12)


def test_default_initial_memory_is_exclude_where_the_kind_can():
    rec = _rec()
    pi = fit_recordings(rec, "pi", n_operators=3)
    assert pi.report.extra["initial_memory"]["rule"] == "exclude"
    mpi = fit_recordings(rec, "mpi", n_operators=3)  # relaxed start only: no error
    assert mpi.memory_note == ""


def test_windows_and_several_recordings():
    recs = [_rec("a"), _rec("b", 1.5)]
    out = fit_recordings(recs, n_operators=3, initial_memory="keep",
                         train=TimeWindow(stop=2.0), test=TimeWindow(2.0, label="2:"))
    fit = out.parameter_set.to_dict()["provenance"]["fit"]
    assert (fit["train"], fit["test"]) == (":2", "2:")
    assert out.report.test.n_samples == sum(int((r.t >= 2.0).sum()) for r in recs)
    with pytest.raises(EmptyWindowError, match="train window 5:6 selects no samples") as exc:
        fit_recordings(recs, train=TimeWindow(5.0, 6.0))
    assert exc.value.which == "train" and isinstance(exc.value, ValueError)
    with pytest.raises(ParameterError, match="start must be smaller"):
        TimeWindow(1.0, 1.0)
    with pytest.raises(ParameterError, match="fit kind|unknown|not one of"):
        fit_recordings(recs, "no-such-kind")


def test_a_misfit_that_changes_with_the_rate_is_said_in_the_recordings_units() -> None:
    # a stop plant with a viscous force c du/dt, recorded at three rates (the same decaying
    # sine in 4, 1 and 0.5 s): the rate-independent stop-pi fit sits between them (too wide a
    # loop at the slowest rate, too narrow at the fastest), and its warning says so, with the
    # largest residual region in mm and N (before: bare numbers, no rate)
    from core.stop import StopPIModel

    plant = StopPIModel(0.5, [0.1, 0.3], [4.0, 2.0])
    rng = np.random.default_rng(3)
    recs = []
    for name, period in (("slow", 4.0), ("mid", 1.0), ("fast", 0.5)):
        t = np.arange(0.0, 5 * period, period / 400)
        u = np.sin(2 * np.pi * t / period) * (1 - 0.5 * t / t[-1])
        y = plant(u) + 0.05 * np.gradient(u, t) + 1e-3 * rng.standard_normal(t.size)
        recs.append(Recording(t, u, y, name, units={"input": "mm", "output": "N"}))
    out = fit_recordings(recs, "stop-pi")
    (msg,) = [w for w in out.warnings if "white-noise floor" in w]
    assert " mm (RMS " in msg and " N)" in msg
    assert "the misfit changes with the input's rate" in msg
    assert msg.index("on slow (mean speed") < msg.index("on fast (mean speed")
    assert "the loops widen as the input speeds up: a viscous force" in msg


def test_an_inverse_that_does_not_recover_the_input_is_said_in_words() -> None:
    """On the shipped 36 lb friction damper the stop base is invertible, but on its friction
    plateaus the force does not determine the displacement: the inverse, applied to the
    measured force, misses the measured input by far more than its range, and the fit says
    so in the input's unit. On the shipped piezo recording it recovers the input, and says
    nothing."""
    from core.csvio import read_recording
    from core.datasets import DATA_DIR
    from core.fitting.entry import INVERSE_WARN_PCT

    damper = read_recording(DATA_DIR / "friction_damper" / "1Hz36lbtension0.5amplitude.csv")
    out = fit_recordings(damper, "stop-pi", n_operators=15)
    part = out.report.test
    assert out.report.invertible and part is not None
    assert part.inverse_input_rmse_pct > 10 * INVERSE_WARN_PCT
    said = [w for w in out.warnings if w.startswith("the inverse of this model")]
    assert len(said) == 1 and "in RMS" in said[0] and "friction plateau" in said[0]
    assert said[0] in out.parameter_set.provenance.fit["warnings"]

    piezo = read_recording(DATA_DIR / "piezo" / "piezo_150V_1Hz.csv")
    out = fit_recordings(piezo, "pi", n_operators=10)
    assert out.report.test is not None
    assert out.report.test.inverse_input_rmse_pct < INVERSE_WARN_PCT
    assert not any(w.startswith("the inverse of this model") for w in out.warnings)
