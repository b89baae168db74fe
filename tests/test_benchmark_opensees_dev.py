"""The development OpenSees plants (benchmarks/diagnosis/opensees_plants.py DEV_MATERIALS):
the sealed set's three OpenSees laws with other parameters, driven by the bipolar
development recordings, registered as development cases of classes of their own and never
the sealed plants themselves. Fast: no diagnosis runs here."""

from __future__ import annotations

import numpy as np
import pytest

from benchmarks.diagnosis.bipolar import BIPOLAR_RECORDINGS, make_bipolar
from benchmarks.diagnosis.families import BASES, OPENSEES_DEV_BASES, STROKE, make_base
from benchmarks.diagnosis.opensees_plants import DEV_MATERIALS, MATERIALS, StrainDriven
from benchmarks.diagnosis.sealed import SEALED_CASES
from benchmarks.diagnosis.sets import CLASSES, DEV_CASES, build, case_class
from tests.test_benchmark_sealed import needs_opensees, signed_area


def test_the_development_laws_are_the_sealed_kinds_with_other_parameters() -> None:
    assert set(OPENSEES_DEV_BASES) == set(DEV_MATERIALS)
    sealed = {m.kind: m.args for m in MATERIALS.values()}
    for name, law in DEV_MATERIALS.items():
        assert law.kind in sealed, name
        assert law.args != sealed[law.kind], name  # never the sealed plant itself
    # the family classes of classes.py run every base of BASES: these are not among them
    assert not set(OPENSEES_DEV_BASES) & set(BASES)


@needs_opensees
@pytest.mark.parametrize("name", OPENSEES_DEV_BASES)
def test_a_strain_driven_law_is_the_material_scaled_and_turns_clockwise(name: str) -> None:
    t = np.linspace(0.0, 2.0, 4001)
    u = 150.0 * np.sin(2 * np.pi * t)  # V
    p = make_base(name)
    y = p(u)
    # the OpenSees law itself along the strain the input stands for (±150 V -> ±6 mm/m)
    np.testing.assert_allclose(y, p.gain * DEV_MATERIALS[name](0.04 * u), rtol=0, atol=1e-12)
    assert isinstance(p, StrainDriven) and p.strain_per_volt == 0.04
    # make_base's scaling: a 0 -> 150 -> 0 V sweep spans the stroke
    sweep = np.concatenate((np.linspace(0, 150, 601), np.linspace(150, 0, 601)[1:]))
    assert np.ptp(p(sweep)) == pytest.approx(STROKE, rel=1e-9)
    assert signed_area(u[2000:], y[2000:]) < -0.01 * np.ptp(u) * np.ptp(y)  # clockwise


def test_development_opensees_cases_are_of_their_own_classes() -> None:
    cases = [c for c in DEV_CASES if c.startswith("dev/opensees")]
    for b in OPENSEES_DEV_BASES:
        cs = [c for c in cases if c.split("/")[2] == b]
        # four effects, two nulls, five single recordings
        assert sum("/large/" in c for c in cs) == 4, b
        assert sum("/null/" in c for c in cs) == 2, b
        assert sum(c.startswith("dev/opensees-single/") for c in cs) == 5, b
    assert {case_class(c) for c in cases} == {"OpenSees non-PI base",
                                              "single-recording OpenSees null"}
    assert {"OpenSees non-PI base", "single-recording OpenSees null"} <= set(CLASSES)
    assert not set(cases) & set(SEALED_CASES)


@needs_opensees
def test_a_development_opensees_case_is_the_law_plus_noise_plus_the_effect() -> None:
    sc = build("dev/opensees/os-steel02-dev/drift/large/1700")
    null = make_bipolar("os-steel02-dev", None, seed=1700)
    assert [r.name for r in sc.records] == list(BIPOLAR_RECORDINGS)
    assert sc.extras["base"] == "os-steel02-dev" and set(sc.extras["hidden"]) == {"drift"}
    p = make_base("os-steel02-dev")
    for r, n in zip(sc.records, null.records, strict=True):
        # the null is the law plus white noise of 0.2 % of the stroke
        e = n.y - p(n.u)
        assert np.std(e) == pytest.approx(0.002 * STROKE, rel=0.1)
        assert abs(np.corrcoef(e[1:], e[:-1])[0, 1]) < 0.05
        # the same noise stream (seed 1700): what the case adds is slow, a drift, not noise
        d = r.y - n.y
        assert np.ptp(d) > 0.005 * STROKE
        assert np.std(np.diff(d)) < 1e-3 * np.std(e)
    one = build("dev/opensees-single/os-pinched-dev/staircase/1700")
    assert [r.name for r in one.records] == ["staircase"] and not one.extras["hidden"]
