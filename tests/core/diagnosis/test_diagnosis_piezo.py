"""The real piezo recording (shipped copy): the diagnosis table of docs/pages/diagnose.md, pinned
for both hold-out protocols. Output range = max - min of the measured y on [7, 9] s (39.31 um), the
fit reports' definition."""

from __future__ import annotations

import numpy as np
import pytest

from core.datasets import load_dataset
from core.diagnosis import diagnose


@pytest.fixture(scope="module")
def piezo():
    rec = load_dataset("piezo-150V-1Hz")
    test = (rec.t >= 7.0) & (rec.t <= 9.0)
    return rec, test, float(np.ptp(rec.y[test]))


def _pct(rec, model, first, test, yr) -> float:
    """% of range on [7, 9] s of ``model`` simulated from sample ``first`` on."""
    e = (rec.y[first:] - model(rec.u[first:], dt=rec.dt))[test[first:]]
    return 100.0 * float(np.sqrt(np.mean(e * e))) / yr


@pytest.mark.slow
def test_windowed_protocol_test_window_scored_once(piezo) -> None:
    """--train 3.3:7 --test 7:9 on the whole file (fixed 25-operator grid): selection by
    cross-fitting the training window, the test window only scored. Measured 2026-12-01:
    PI 0.286 %, + initial-memory 0.184 %, + lag (tau 8.1 ms) 0.149 %."""
    rec, test, yr = piezo
    res = diagnose(rec, train=(3.3, 7.0), test=(7.0, 9.0), n_operators=25,
                   auto_resolution=False)
    assert "never used for selection" in res.split
    assert "test window (scored only, never used for selection)" in res.summary()
    assert [e.name for e in res.effects][:2] == ["initial-memory", "lag"]
    assert 0.006 < res.effects[1].parameters["tau_s"] < 0.010
    assert 100 * res.heldout_rmse(res.baseline) / res.y_range == pytest.approx(0.286, abs=0.01)
    final = _pct(rec, res.model, 0, test, yr)
    assert final == pytest.approx(100 * res.heldout_rmse(res.final) / res.y_range, rel=1e-9)
    assert final <= 0.15
    # a candidate is said to be left because a higher-priority family passed only in a
    # round where one did (the loop shapes of the last round made the training error worse)
    passed = {r.round for r in res.rounds if r.passes}
    for r in res.rounds:
        if r.decision == "deferred" and "higher-priority family passed" in r.evidence:
            assert r.round in passed, (r.round, r.effect)
    assert any(r.decision == "deferred" and "does not lower the training error" in r.evidence
               for r in res.rounds)


@pytest.mark.slow
def test_strict_protocol_only_the_training_rows_exist(piezo) -> None:
    """The tool gets only the rows t in [3.3, 7) s (it never sees t >= 7 s; the recording
    starts mid-history) and the default automatic grid; the diagnosed model, simulated from
    3.3 s on, predicts [7, 9] s within 0.15 % of range. Measured: 0.146 %."""
    rec, test, yr = piezo
    res = diagnose(rec.window(3.3, 7.0), train=(-np.inf, np.inf), n_operators=25)
    assert res.crossval is not None and not np.isfinite(res.heldout_rmse(res.final))
    assert res.effects and res.effects[0].name == "initial-memory"
    assert res.effects[0].evidence.startswith("training rows before the wipe-out")
    first = int(np.searchsorted(rec.t, 3.3 - 1e-9))
    assert _pct(rec, res.model, first, test, yr) <= 0.15


@pytest.mark.slow
def test_no_windows_the_saved_model_is_refitted_on_every_row(piezo) -> None:
    """Issue 16, failure 6: only the rows t in [3.3, 7) s and no windows. The interleaved test
    blocks serve selection; the saved model is the selected structure refitted on every row
    (before: fitted on the training blocks only, 0.158 % on [7, 9] s; now 0.148 %)."""
    rec, test, yr = piezo
    res = diagnose(rec.window(3.3, 7.0))
    assert res.refit is not None and res.refit.structure == res.final.structure
    assert res.refit.n_train > res.final.n_train
    first = int(np.searchsorted(rec.t, 3.3 - 1e-9))
    saved = _pct(rec, res.model, first, test, yr)
    assert saved < _pct(rec, res.final.models[0], first, test, yr)
    assert saved <= 0.15
    doc = res.to_dict()
    assert doc["final"]["model_fitted_on"].startswith("every row")


#: The README's diagnosis of the shipped file (``hyst diagnose piezo_150V_1Hz.csv``, default
#: options), measured 2026-12-05 with the whole-text reader: (round, effect, passes, dm_z).
#: (drift's z moved -5.580 -> -4.859 and 3.621 -> 2.502 when its cycle-to-cycle rows came to
#: start at the input's rising crossings, core.fitting.cycles, instead of a reversal grid;
#: then -4.859 -> -10.579 and 2.502 -> -2.112 when each cycle's residual came to be compared
#: with the cycle before it, from the third cycle on, instead of about its mean)
#: (the resonance's two numbers since round 5's finer search grid for the mode, d91d968:
#: -0.160 -> -0.052 and 6.831 -> 7.405; still rejected, every other number unchanged)
#: (creep's two rows since it is tested from cycle to cycle of the repeated sine, as drift
#: is, instead of "untestable: no hold": rejected, z -22.393 and -6.387, the fitted bank
#: making the cycle-to-cycle change worse; every other number unchanged)
#: (creep's and drift's four rows since their weights are fitted on the changes between
#: training cycles, core.diagnosis.changes, instead of beside the base on the raw rows,
#: where they took its misfit: z -22.393 -> 0.551, -10.579 -> -0.847, -6.387 -> -0.196,
#: -2.112 -> -0.847; still rejected, every other number unchanged)
#: (the resonance's two numbers since its refinement starts from a simplex spanning the grid
#: cell, 32 evaluations: -0.052 -> 0.084 and 7.405 -> 7.165; still rejected, every other
#: number unchanged)
PIEZO_TESTED = [
    (1, "delay", False, 0.176), (1, "lag", False, -0.296), (1, "resonance", False, 0.084),
    (1, "creep", False, 0.551), (1, "drift", False, -0.847), (1, "asymmetry", False, 1.441),
    (1, "initial-memory", True, 18.670), (1, "saturation", True, 19.907),
    (1, "dead-zone", True, 16.965), (1, "resolution:50", True, 2.261),
    (1, "resolution:100", False, 2.329), (2, "delay", False, 7.288), (2, "lag", False, 7.431),
    (2, "resonance", False, 7.165), (2, "creep", False, -0.196), (2, "drift", False, -0.847),
    (2, "asymmetry", False, 2.967),
    (2, "saturation", False, 2.269), (2, "dead-zone", False, -5.813)]


@pytest.mark.slow
def test_the_shipped_diagnosis_through_the_block_reader(monkeypatch) -> None:
    """Issue 31: the shipped file read in blocks (core.csvio.stream, forced here: the file is
    below the 8 MiB where blocks start) is the recording the whole-text reader gives, bit for
    bit, and its diagnosis has the names and numbers the whole-text reader's had."""
    from pathlib import Path

    from core.csvio import CsvOptions, load, read_csv, stream

    path = Path(__file__).parents[3] / "examples" / "data" / "piezo" / "piezo_150V_1Hz.csv"
    (whole,) = read_csv(path)
    monkeypatch.setattr(stream, "STREAM_FROM_BYTES", 0)
    monkeypatch.setattr(stream, "BLOCK_BYTES", 64 * 1024)
    assert isinstance(load.read_table(path, CsvOptions())[0], stream.StreamedTable)
    (blocks,) = read_csv(path)
    for k in ("t", "u", "y", "lines"):
        np.testing.assert_array_equal(getattr(blocks, k), getattr(whole, k))
    assert (blocks.cleaning, dict(blocks.units), blocks.name) == (
        whole.cleaning, dict(whole.units), whole.name)
    res = diagnose(path)
    assert [e.name for e in res.effects] == ["initial-memory"]
    assert res.effects[0].parameters["history"] == [[-126.0]]
    assert res.heldout_rmse(res.baseline) == pytest.approx(0.7603972281, rel=1e-6)
    assert res.heldout_rmse(res.final) == pytest.approx(0.1069648139, rel=1e-6)
    assert res.y_range == pytest.approx(39.337159, rel=1e-9)
    tested = [(r.round, r.effect, r.passes, r.dm_z) for r in res.rounds]
    assert [t[:3] for t in tested] == [t[:3] for t in PIEZO_TESTED]
    np.testing.assert_allclose([t[3] for t in tested], [t[3] for t in PIEZO_TESTED], atol=2e-3)
