"""Cross-fitting folds whose grid searches start from the full-data estimate
(:func:`core.diagnosis.candidates.walk_down`, ``FitContext.start``) against the whole grid."""

from __future__ import annotations

import numpy as np
import pytest

import core.diagnosis.judge as judge
import core.diagnosis.search as search
from core.diagnosis import diagnose
from core.diagnosis.candidates import walk_down
from core.diagnosis.context import FitContext
from core.stages import Lag
from tests.core.diagnosis.test_diagnosis import _records


@pytest.mark.parametrize("shape", [(18,), (7, 3), (5, 6)])
def test_walk_finds_the_minimum_of_a_grid_with_one_local_minimum(shape) -> None:
    rng = np.random.default_rng(len(shape) * 10 + shape[0])
    for _ in range(20):
        c = rng.uniform(-0.5, np.array(shape) - 0.5)
        scale = rng.uniform(0.2, 3.0, len(shape))
        seen: list = []

        def value(ij, c=c, scale=scale, seen=seen):
            seen.append(ij)
            return float(np.sum(scale * (np.asarray(ij) - c) ** 2))

        grid = {ij: value(ij) for ij in np.ndindex(*shape)}
        truth = min(grid, key=grid.get)
        seen.clear()
        start = tuple(int(rng.integers(0, m)) for m in shape)
        assert walk_down(value, shape, start) == truth
    # from next to the minimum: a fraction of the grid evaluated
    seen.clear()
    near = tuple(min(int(round(x)) + 1, m - 1) for x, m in zip(c, shape, strict=True))
    walk_down(value, shape, near)
    assert len(set(seen)) < np.prod(shape) or np.prod(shape) <= 9


def test_walk_stops_at_the_local_minimum_it_starts_in() -> None:
    # the documented limitation: a deeper minimum beyond a hump is not seen
    v = np.array([3.0, 1.0, 2.0, 5.0, 2.0, 0.0, 4.0])
    assert walk_down(lambda ij: v[ij[0]], v.shape, (2,)) == (1,)
    assert walk_down(lambda ij: v[ij[0]], v.shape, (4,)) == (5,)


def _crossfits(monkeypatch, shortcut: bool) -> dict:
    """Every cross-fitting of a lag plant diagnosed with explicit windows (strict hold-out),
    by candidate name; ``shortcut=False``: the folds search their whole grids."""
    out: dict = {}
    orig = search.crossfit_candidate

    def spy(ctx, name, cur, fit):
        cf = orig(ctx, name, cur, fit)
        out.setdefault(name, []).append(cf)
        return cf

    for part in (search, judge):  # the two places that cross-fit a candidate
        monkeypatch.setattr(part, "crossfit_candidate", spy)
    if not shortcut:  # the folds never learn the full-data estimate
        monkeypatch.setattr(FitContext, "start", property(lambda self: None,
                                                          lambda self, v: None), raising=False)
    recs = _records(extra=Lag(0.004), noise=0.01, seed=3)
    diagnose(recs, train=(0.0, 2.0), test=(2.0, 2.5), n_operators=10, auto_resolution=False,
             effects=["delay", "lag", "resonance"])
    monkeypatch.undo()
    return out


def test_fold_estimates_are_those_of_the_whole_grid(monkeypatch) -> None:
    fast = _crossfits(monkeypatch, True)
    full = _crossfits(monkeypatch, False)
    # the one-parameter and the two-parameter searches were both cross-fitted
    assert {"lag", "delay", "resonance"} <= set(full)
    assert fast.keys() == full.keys()
    for name, cfs in full.items():
        assert len(fast[name]) == len(cfs)
        for a, b in zip(fast[name], cfs, strict=True):
            assert (a is None) == (b is None)
            if b is None:
                continue
            assert len(a.fold_parameters) == len(b.fold_parameters) >= 2
            for pa, pb in zip(a.fold_parameters, b.fold_parameters, strict=True):
                assert pa.keys() == pb.keys()
                for k in pb:
                    assert pa[k] == pytest.approx(pb[k], rel=1e-9), (name, k)
            assert a.parameter_cv == pytest.approx(b.parameter_cv, rel=1e-9)
            assert a.pooled.z == pytest.approx(b.pooled.z, rel=1e-9)
