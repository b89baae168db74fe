"""The fitting context of a diagnosis: recordings, row masks, folds, caches."""

from __future__ import annotations

from functools import reduce
from typing import TYPE_CHECKING

import numpy as np

from .._typing import Float1D
from ..fitting.thresholds import wipeout_index
from ..recordings import Recording
from .bankcache import BankCache
from .cache_budget import FIT, cache_budget
from .changes import changed_terms, weights_on_changes
from .locate import Coordinates, coordinates
from .registry import term_of
from .structure import Fit, HeldWeights, PIStageOutputs, Structure, fit_structure

if TYPE_CHECKING:
    from .registry import SignatureRows

__all__ = ["FitContext"]

#: Fits the memo of one diagnosis holds at most (:meth:`FitContext.fit`), and the most
#: recent ones it keeps whatever the cache budget (their bytes count in it): 48 fits of a
#: 50,000-sample recording hold 19 MB of predictions (38 MB with their PI-stage outputs); of
#: a 10-million-sample one, 3.8 GB. Past the budget (:mod:`.cache_budget`, shared with the
#: play banks and their derived arrays, which go first) the least recently used fits go.
FIT_MEMO_COUNT = 48
FIT_MEMO_MIN = 4


def _fit_bytes(f: Fit) -> int:
    """Bytes of the per-sample arrays a memoised fit holds or will hold: its predictions and
    its PI-stage outputs (formed on first use, counted from the start)."""
    pred = sum(p.nbytes for p in f.pred)
    if f.x_pi is None:
        return pred
    if isinstance(f.x_pi, PIStageOutputs):  # not formed yet: N values per recording
        return 2 * pred
    return pred + sum(np.asarray(v).nbytes for v in f.x_pi)


def block_means(e: Float1D, block: int) -> Float1D:
    """The mean of ``e`` (shape ``(n,)``) over the ``block`` rows ending at each row (the
    first ``block - 1`` rows: over the rows there are); ``e`` itself for ``block`` 1."""
    if block <= 1:
        return e
    c = np.concatenate(([0.0], np.cumsum(e)))
    hi = np.arange(1, e.size + 1)
    lo = np.maximum(hi - block, 0)
    return (c[hi] - c[lo]) / (hi - lo)


class FitContext:
    """Recordings, train/test rows, cross-fitting folds and the shared play-bank cache of one
    diagnosis; :meth:`fit` solves a structure on the training rows."""

    def __init__(self, records, train, test, folds=None, parent: FitContext | None = None) -> None:
        self.records: list[Recording] = records
        self.train: list[np.ndarray] = train
        self.test: list[np.ndarray] = test
        #: full fits memoised by (training rows, structure, refreshes, bilinear start): the
        #: folds refit the same current structure for every candidate and comparison
        self._fits: dict = {}
        #: the caches of the sub-contexts of one diagnosis by their training masks (the
        #: cross-fitting folds recur for every candidate and comparison)
        self._caches: dict = {}
        if parent is None:
            self.cache = BankCache(cache_budget(sum(r.n_samples for r in records)))
            self.cache.budget.floor[id(self._fits)] = FIT_MEMO_MIN
        else:
            self._fits = parent._fits
            self._caches = parent._caches
            self.cache = self._sub_cache(parent.cache)
        self.coords: list[Coordinates] = (coordinates(records) if parent is None
                                          else parent.coords)
        self.n_train = sum(int(m.sum()) for m in train)
        #: refreshes of the bilinear (creep, asymmetry) regressors per fit; None = default
        self.iterations: int | None = None
        #: blocked cross-validation folds over the training rows (explicit windows only)
        self.folds: list[tuple[list[np.ndarray], list[np.ndarray]]] = list(folds or [])
        #: strict hold-out: decisions rest on the folds only, the test rows are only scored
        self.strict = False
        #: a sub-context (cross-fitting fold) of a strict hold-out: its candidates are judged
        #: on the folds' raw rows, so no term is fitted on changes (:mod:`.changes`)
        self.within_strict: bool = parent is not None and (parent.strict
                                                           or parent.within_strict)
        #: estimate the candidates' parameter uncertainties (profile curvature); off where
        #: only the parameters are used (cross-fitting folds)
        self.uncertainty = True
        #: acceptance rule 14's residuals of one current fit per held-out event window
        #: (:func:`~core.diagnosis.judge.event_gains`): ``"cur"`` the fit they are of and the
        #: settings it was refitted under, then ``(a, b)`` its residuals on window ``a:b``
        #: refitted without it; every candidate judged on that fit reads the same ones
        self.event_residuals: dict = {}
        #: a cross-fitting fold: the candidate's structure fitted on all the training rows,
        #: whose nonlinear parameters a one-parameter search starts from
        #: (:func:`core.diagnosis.candidates.scalar_search`); None elsewhere
        self.start: Structure | None = None
        #: the recordings depart from Masing's rule beyond their noise
        #: (:attr:`core.fitting.masing.Masing.departs`) and the base obeys it (a play, stop
        #: or Preisach base): a history's first visit still settles, so a change with time
        #: is judged between branches of the same history only from its second visit on
        #: (:func:`~core.diagnosis.periodic.same_history`)
        self.unsettled_memory: bool = parent is not None and parent.unsettled_memory

    def _sub_cache(self, parent: BankCache) -> BankCache:
        """The cache of a sub-context: play banks and projections do not depend on the rows
        used and are shared with ``parent``; the bases and row layouts do, so they are
        shared only with earlier sub-contexts on the same recordings and training masks
        (the registry entry keeps those alive, so their identities stay unique)."""
        key = (tuple(id(r) for r in self.records), tuple(id(m) for m in self.train))
        hit = self._caches.get(key)
        if (hit is not None and all(a is b for a, b in zip(hit[0], self.records, strict=True))
                and all(a is b for a, b in zip(hit[1], self.train, strict=True))
                and hit[2].d is parent.d):
            return hit[2]
        c = BankCache(parent.budget)
        c.d, c.p, c.rp, c.lv, c.bw = parent.d, parent.p, parent.rp, parent.lv, parent.bw
        c.events = parent.events
        if len(self._caches) >= 16:
            self._caches.pop(next(iter(self._caches)))
        self._caches[key] = (list(self.records), list(self.train), c)
        return c

    def fit(self, s: Structure, cur: Fit | None = None) -> Fit:
        """Fit ``s`` on the training rows (bilinear regressors started from ``cur``).

        A static term whose effect is judged on changes between rows of the same input
        history (a drift, creep from cycle to cycle) has its weights fitted on the same
        kind of changes between training rows, then held while the rest is solved on the
        raw training rows (:mod:`core.diagnosis.changes`), so that it cannot absorb the
        base's repeating misfit. Held weights of a term read from the PI-stage output (creep)
        that leave the training rows fitted worse than the structure without the changed
        terms are left to the raw solve instead: the fit's refresh of the PI-stage output
        does not settle under them (a drift's changes regressed on the slow lags); the fit
        records which (:attr:`Fit.raw_fallback`) and the finding says so.

        Deterministic, so memoised: the key holds the identities of the row masks and of
        ``cur``'s PI-stage outputs (used only by creep and asymmetry), whether terms may be
        fitted on changes here (not under strict hold-out, whose sub-contexts share the
        memo and the training masks: the same structure is fitted on the raw rows there),
        and the entry keeps references to them so that those identities cannot be reused
        while it lives.
        """
        x_init = cur.x_pi if cur is not None else None
        uses_x = s.reads_output
        key = (tuple(id(m) for m in self.train), s, self.iterations,
               id(x_init) if uses_x else None, self.strict or self.within_strict)
        hit = self.cache.budget.get(self._fits, key)
        if hit is not None:
            return hit[2]
        held: tuple[HeldWeights, ...] = ()
        f0: Fit | None = None
        names, sig = changed_terms(self, s)
        if sig is not None:
            # a slow term judged on changes between rows of the same history is fitted on
            # those changes (:mod:`.changes`), the rest on the raw rows around it
            f0 = self.fit(reduce(lambda a, n: a.with_term(n, term_of(n).off), names, s), cur)
            held = weights_on_changes(self, s, names, sig, f0)
        f = fit_structure(s, self.records, self.train, self.cache, x_init,
                          iterations=self.iterations, held=held)
        outer = tuple(h for h in held if not term_of(h.name).through_dynamics)
        if f0 is not None and len(outer) < len(held) and f.train_rss > f0.train_rss:
            # held weights of a term read from the PI-stage output (creep) that leave the
            # training rows fitted worse than without the term: left to the raw solve
            f = fit_structure(s, self.records, self.train, self.cache, x_init,
                              iterations=self.iterations, held=outer)
            assert isinstance(f, Fit)
            f.raw_fallback = tuple(h.name for h in held if term_of(h.name).through_dynamics)
        assert isinstance(f, Fit)
        # (at most FIT_MEMO_COUNT fits, within the cache budget beside the banks, the
        # FIT_MEMO_MIN most recent kept whatever it: a fit holds N predictions per recording)
        self.cache.budget.put(self._fits, key, (list(self.train), x_init, f), _fit_bytes(f),
                              FIT, count=FIT_MEMO_COUNT)
        return f

    def rss(self, s: Structure, cur: Fit) -> float:
        """Training RSS of the linear solve (bilinear regressors frozen at ``cur``)."""
        v = fit_structure(s, self.records, self.train, self.cache, cur.x_pi, iterations=1,
                          rss_only=True)
        assert isinstance(v, float)
        return v

    def test_res(self, f: Fit, masks: list[np.ndarray] | None = None) -> list[Float1D]:
        ms = self.test if masks is None else masks
        return [(r.y - p)[m] for r, p, m in zip(self.records, f.pred, ms, strict=True)]

    def signature_res(self, f: Fit, sig: SignatureRows) -> list[Float1D]:
        """The residuals of ``f`` on the test rows an effect's signature lives in (``sig``):
        each row's change from the row one cycle before where ``sig.previous`` gives one
        (with ``sig.block`` rows: the change of the residual's mean over the ``block`` rows
        ending at each), else as they are."""
        where = [m & t for m, t in zip(sig.masks, self.test, strict=True)]
        if sig.previous is not None:
            out = []
            for k, (r, p, w, prev) in enumerate(zip(self.records, f.pred, where,
                                                    sig.previous, strict=True)):
                e = block_means(r.y - p, sig.block_of(k))
                out.append(e[w] - e[prev[w]])
            return out
        return self.test_res(f, where)

    @property
    def memory_masks(self) -> list[np.ndarray]:
        """The pre-wipe-out rows: the only rows an initial memory state affects."""
        out = []
        for r in self.records:
            m = np.zeros(r.n_samples, dtype=bool)
            m[: wipeout_index(r.u)] = True
            out.append(m)
        return out

    def all_res(self, f: Fit) -> list[Float1D]:
        return [r.y - p for r, p in zip(self.records, f.pred, strict=True)]
