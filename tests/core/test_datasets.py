"""The shipped real recordings: one call each, right sizes/units, identical to the shared copy."""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path

import numpy as np
import pytest

from core.datasets import DATA_DIR, DatasetError, dataset_info, list_datasets, load_dataset
from core.recordings import Recording

ROOT = Path(__file__).resolve().parents[2]
SHARED = ROOT.parent / "shared" / "data"
needs_shared = pytest.mark.skipif(not SHARED.is_dir(), reason=f"no shared data at {SHARED}")

# name -> (sample counts per recording, input unit, output unit, sampling rate or None)
EXPECTED = {
    "piezo-150V-1Hz": ([50_001], "V", "µm", 5000.0),
    "friction-0.25Hz-30lb": ([28 * 1024 + 1], "in", "kip", 1024.0),
    "friction-1Hz-30lb": ([7 * 1024 + 1], "in", "kip", 1024.0),
    "friction-1Hz-36lb": ([7 * 1024 + 1], "in", "kip", 1024.0),
    "friction-2Hz-30lb": ([3584 + 1], "in", "kip", 1024.0),
    "bh-MnZn-ferrite": ([129] * 4, "A/m", "T", None),
    "bh-MnZn-HP-ferrite": ([129] * 4, "A/m", "T", None),
    "bh-M130-27s-GO-steel": ([256] * 3, "A/m", "T", None),
    "bh-amorphous-alloy": ([322], "A/m", "T", None),
}


def test_list_datasets_names_every_shipped_recording():
    assert list_datasets() == list(EXPECTED)


@pytest.mark.parametrize("name", list(EXPECTED))
def test_every_dataset_loads_with_one_call(name):
    counts, u_unit, y_unit, fs = EXPECTED[name]
    got = load_dataset(name)
    info = dataset_info(name)
    recs = got if isinstance(got, list) else [got]
    assert isinstance(got, list) == info.per_loop
    assert [r.n_samples for r in recs] == counts
    for k, r in enumerate(recs):
        assert isinstance(r, Recording)
        assert r.units["input"] == u_unit and r.units["output"] == y_unit
        assert r.citation == info.citation and "Licence" in r.citation
        assert Path(r.source) == info.path()
        assert r.cleaning == () or all("sample index" in c for c in r.cleaning)
        if fs is None:  # B-H loops: no time axis, one recording per loop
            assert not r.has_time and r.run == k
            np.testing.assert_array_equal(r.t, np.arange(r.n_samples))
            np.testing.assert_array_equal(r.extra["k"], np.arange(r.n_samples))
            # one loop = constant peak field, and the loop reaches it
            assert np.ptp(r.extra["Hpk"]) == 0
            assert np.max(np.abs(r.u)) == pytest.approx(r.extra["Hpk"][0], rel=0.01)
        else:
            assert r.has_time and r.is_uniform
            assert r.fs == pytest.approx(fs, rel=1e-9)
            assert r.t[0] == 0.0


def test_licence_and_attribution_ship_with_every_folder():
    for name in list_datasets():
        info = dataset_info(name)
        folder = DATA_DIR / info.folder
        assert (folder / info.licence_file).is_file()
        attribution = (folder / "ATTRIBUTION.md").read_text(encoding="utf-8")
        assert info.file in attribution
        assert name in attribution
    mit = (DATA_DIR / "piezo" / "LICENSE").read_text()
    assert "MIT License" in mit and "chandratue" in mit
    cc = (DATA_DIR / "friction_damper" / "LICENSE.txt").read_bytes()  # cp1252 quotes inside
    assert cc.startswith(b"Attribution-ShareAlike 4.0 International")
    assert "Roman Szewczyk" in (DATA_DIR / "bh_loops" / "LICENSE").read_text()


@needs_shared
def test_shipped_files_are_byte_identical_to_the_shared_copy():
    shared = sorted(p.relative_to(SHARED) for p in SHARED.rglob("*") if p.is_file()
                    and p.name != "README.md")
    assert shared, "shared data folder is empty"
    for rel in shared:
        a = hashlib.sha256((SHARED / rel).read_bytes()).hexdigest()
        b = hashlib.sha256((DATA_DIR / rel).read_bytes()).hexdigest()
        assert a == b, rel


@needs_shared
@pytest.mark.parametrize("name", ["piezo-150V-1Hz", "friction-2Hz-30lb", "bh-MnZn-ferrite"])
def test_loaded_values_equal_an_independent_numpy_parse_of_the_shared_copy(name):
    info = dataset_info(name)
    raw = np.loadtxt(SHARED / info.folder / info.file, delimiter=",", skiprows=1)
    got = load_dataset(name)
    recs = got if isinstance(got, list) else [got]
    if info.per_loop:  # columns loop, k, Hpk, u, y
        for r in recs:
            rows = raw[raw[:, 0] == r.run]
            np.testing.assert_array_equal(r.u, rows[:, 3])
            np.testing.assert_array_equal(r.y, rows[:, 4])
            np.testing.assert_array_equal(r.extra["Hpk"], rows[:, 2])
        assert sum(r.n_samples for r in recs) == raw.shape[0]
    else:
        (r,) = recs
        np.testing.assert_array_equal(r.t, raw[:, 0])
        np.testing.assert_array_equal(r.u, raw[:, 1])
        np.testing.assert_array_equal(r.y, raw[:, 2])
        for j, key in enumerate(r.extra, start=3):
            np.testing.assert_array_equal(r.extra[key], raw[:, j])


def test_piezo_matches_its_documented_shape():
    """README: 0 V rest, jump to about -87 V, then a ±150 V sine."""
    r = load_dataset("piezo-150V-1Hz")
    assert r.u[0] == 0.0
    assert r.u.max() == pytest.approx(150, abs=2) and r.u.min() == pytest.approx(-150, abs=2)
    assert r.duration == pytest.approx(10.0)


def test_friction_extra_channels_keep_their_units():
    r = load_dataset("friction-1Hz-30lb")
    assert dict(r.extra_units) == {"velocity": "in/s", "act_force1": "lb", "act_force2": "lb"}
    assert r.columns["input"] == "u_disp_in" and r.columns["output"] == "y_force_kip"


def test_unknown_name_lists_the_known_ones_and_the_closest():
    with pytest.raises(DatasetError, match=r"did you mean 'piezo-150V-1Hz'.*known datasets"):
        load_dataset("piezo-150V-1hz")
    with pytest.raises(ValueError, match="unknown dataset"):
        load_dataset("nothing-like-it")


def test_missing_data_folder_says_where_it_looked(tmp_path):
    with pytest.raises(DatasetError, match=r"piezo_150V_1Hz.csv is missing.*data_dir="):
        load_dataset("piezo-150V-1Hz", data_dir=tmp_path)


def test_missing_licence_refuses_to_load(tmp_path):
    (tmp_path / "bh_loops").mkdir()
    shutil.copy(DATA_DIR / "bh_loops" / "amorphous_alloy.csv", tmp_path / "bh_loops")
    with pytest.raises(DatasetError, match=r"licence file .*LICENSE is missing"):
        load_dataset("bh-amorphous-alloy", data_dir=tmp_path)
    shutil.copy(DATA_DIR / "bh_loops" / "LICENSE", tmp_path / "bh_loops")
    (rec,) = load_dataset("bh-amorphous-alloy", data_dir=tmp_path)
    assert rec.n_samples == 322


def test_train_test_windows_on_the_piezo_recording():
    """The split used by the real-data fits: train t in [3.3, 7), test t in [7, 9]."""
    r = load_dataset("piezo-150V-1Hz")
    train = r.window(3.3, 7.0)
    test = r.window(7.0, 9.0, closed="both")
    assert train.n_samples == round(3.7 * 5000) and test.n_samples == 2 * 5000 + 1
    assert train.t[-1] < 7.0 <= test.t[0] and test.t[-1] == 9.0
    np.testing.assert_array_equal(test.y, r.y[(r.t >= 7.0) & (r.t <= 9.0)])
