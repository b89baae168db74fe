"""The play-bank cache of the structure fits (:mod:`core.diagnosis.structure`).

:class:`BankCache` holds, for one diagnosis, the play banks by recording, history and loop
shape, their level segments, reduced bases and projections, the row layout of the solved
rows and the Gram blocks of the PI-stage columns, all within the diagnosis's byte budget
(:mod:`.cache_budget`). The reduced basis of a ranking solve (:func:`reduced_basis`) and
the level split of a bank (:func:`split_levels`) are here too.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..operators import play_bank
from ..preisach import level_segments
from ..recordings import Recording
from ..stages import rd_play_bank
from .bases import element_bank
from .cache_budget import BANK, DERIVED, FIT, CacheBudget
from .events import event_starts
from .rowkernels import bank_rows_times, play_rows, row_selector
from .screening import ranking_span
from .shapes import apply_shape, output_gains, signed_ratio

if TYPE_CHECKING:
    from .structure import Structure

__all__ = ["DEFAULT_CACHE_BYTES", "FULL_FIT_ROWS", "RANKING_ROWS", "BankCache", "basis_of",
           "basis_rows", "recent", "reduced_basis", "split_levels"]


#: Training rows a full (constrained) structure fit solves its weights on, about: every
#: ``k``-th training row, ``k = n_train // FULL_FIT_ROWS`` (all rows below twice as many).
#: Neighbouring samples of a recording sampled far above its dynamics are nearly redundant:
#: only the least-squares rows are thinned (the plays and output filters still run over
#: every sample), and the fit's residuals, training RSS and every held-out score come from
#: its exact simulation on all rows.
FULL_FIT_ROWS = 15000


#: Training rows a ranking solve (``rss_only``: the searches over nonlinear parameters)
#: uses, about (as :data:`FULL_FIT_ROWS`).
RANKING_ROWS = 8000


#: Byte limit of a cache made without a budget (tests, a fit outside a diagnosis): what the
#: separate budgets of the play banks, level segments and projections held together before
#: the one budget of :mod:`.cache_budget`. A diagnosis's cache has :func:`cache_budget` of
#: its samples instead.
DEFAULT_CACHE_BYTES = 384e6


class BankCache:
    """Play-bank outputs keyed by (recording, history, beta), their reduced bases, the
    projections of the banks on those bases and the row layout of the training rows.

    ``budget``: the byte account the play banks, level segments, projections and Bouc-Wen
    history banks share with the diagnosis's fit memo (:class:`~.cache_budget.CacheBudget`,
    limit :func:`~.cache_budget.cache_budget` of its samples), or a limit in bytes for a new
    account (:data:`DEFAULT_CACHE_BYTES` if None)."""

    def __init__(self, budget: CacheBudget | float | None = None) -> None:
        self.budget = (budget if isinstance(budget, CacheBudget)
                       else CacheBudget(DEFAULT_CACHE_BYTES if budget is None else budget))
        self.d: dict[Any, np.ndarray] = {}
        self.v: dict[Any, np.ndarray] = {}
        #: projections ``B @ V``: may be shared between the caches of one diagnosis (the
        #: entry holds ``V``, whose identity is part of the key)
        self.p: dict[Any, tuple[np.ndarray, np.ndarray]] = {}
        #: per recording, the last projection the budget did not keep (:meth:`projected`):
        #: ``(call, V, P)``, shared as :attr:`p` is; a search over the output dynamics asks
        #: for the same product at every trial (:meth:`kept_product`)
        self.rp: dict[Any, tuple[tuple, np.ndarray, np.ndarray]] = {}
        #: row layout per (records, training masks, fast path), entries hold both
        self.rows: dict[Any, tuple] = {}
        #: play banks split into the level segments of a Preisach base
        self.lv: dict[Any, np.ndarray] = {}
        #: banks of a Bouc-Wen base
        self.bw: dict[Any, np.ndarray] = {}
        #: Gram blocks of the PI-stage columns of full fits (play bank through the output
        #: dynamics on the solved rows), keyed by row layout, bank and dynamics: structures
        #: that add columns to the same bank (bilinear refreshes, output maps, creep) reuse it
        self.g: dict[Any, tuple[Any, np.ndarray]] = {}
        #: input events of the recordings by recording id (entries hold the recording): what
        #: the prefixes of their searches hold (:func:`~.screening.ranking_span`)
        self.events: dict[int, tuple[Recording, np.ndarray]] = {}
        #: training masks cut to those prefixes, per training masks (entries hold both)
        self.ranking: dict[Any, tuple] = {}

    def projected(self, B: np.ndarray, V: np.ndarray, key: Any,
                  w: np.ndarray | None = None, start: int = 0,
                  r: np.ndarray | None = None) -> np.ndarray:
        """``(B @ V)[start:]`` memoised on ``key`` (recording, basis key and row count) and the
        identity of ``V``, row-major (the dynamics filter runs time outer, columns inner).

        ``w``: the play-bank input on the rows of ``B`` (rate-independent plays only): where
        it repeats (a hold, a flat stretch before the excitation) the plays do not move and
        the row of ``B`` repeats exactly, so only the distinct rows are multiplied.
        ``start``: the first row needed. A first request forms the rows from ``start`` on; a
        later one for the same ``B`` and ``V`` that starts earlier (a search over the
        dynamics moves it) forms them all, which then serve every start.
        ``r``: the thresholds of the columns when ``B`` is a play bank (column 0 the input):
        the product is then formed by :func:`bank_rows_times` where the input turns rarely.
        """
        held, start0 = self._held(V, key, start)
        if held is not None:
            return held
        call = ((key, id(V)), start0, B.shape[0], w is not None, r is not None)
        P = None
        if r is not None and B.shape[0] > start0:
            P = bank_rows_times(B, V, r, np.arange(start0, B.shape[0]))
        B = B[start0:]
        w = None if w is None else w[start0:]
        # room first: the caches and the new product stay within the budget together
        self.budget.make_room(8.0 * B.shape[0] * V.shape[1])
        if P is None and w is not None and w.size > 1:
            new = np.empty(w.size, dtype=bool)
            new[0] = True
            np.not_equal(w[1:], w[:-1], out=new[1:])
            if np.count_nonzero(new) < 0.9 * w.size:
                P = (B[new] @ V)[np.cumsum(new) - 1]
        if P is None:
            P = np.ascontiguousarray(B @ V)
        self._keep(call, V, P)
        return P[start - start0:]

    def kept_product(self, V: np.ndarray, key: Any, rows: int, start: int, w: bool,
                     r: bool) -> np.ndarray | None:
        """What :meth:`projected` would return for the bank's first ``rows`` rows, when the
        same product was formed before and is still held (by the budget, or as the last
        product of its recording the budget did not keep: :attr:`rp`); ``None`` otherwise,
        and the bank need not be formed. ``w``, ``r``: whether :meth:`projected` is given
        the bank input and the thresholds. The budget's account moves as that call's would
        (the same reads, room made and entry kept), so what it keeps afterwards is the same,
        and the numbers are those the call forms: the product is reused only for the same
        first row, basis and rows."""
        held, start0 = self._held(V, key, start)
        if held is not None:
            return held
        call = ((key, id(V)), start0, rows, w, r)
        got = self.rp.get(key[0])
        if got is None or got[1] is not V or got[0] != call:
            return None
        P = got[2]
        self.budget.make_room(8.0 * P.shape[0] * V.shape[1])
        self._keep(call, V, P)
        return P[start - start0:]

    def _held(self, V: np.ndarray, key: Any, start: int) -> tuple[np.ndarray | None, int]:
        """The budget's product ``(B @ V)[start:]`` for ``key`` if it holds one from ``start``
        or earlier (a read: the entry becomes the most recently used), and the first row a
        product formed now would start from (0 where the budget's starts later)."""
        hit = self.budget.get(self.p, (key, id(V)))
        if hit is not None and hit[0] is V:
            if hit[2] <= start:
                return hit[1][start - hit[2]:], 0
            return None, 0
        return None, start

    def _keep(self, call: tuple, V: np.ndarray, P: np.ndarray) -> None:
        """Keep the product ``P`` of ``call`` (:meth:`projected`'s key, first row, rows and
        arguments) within the budget, else as its recording's last product (:attr:`rp`)."""
        key, start0 = call[0], call[1]
        if self.budget.put(self.p, key, (V, P, start0), P.nbytes, DERIVED, count=16):
            self.rp.pop(key[0][0], None)
        else:
            self.rp[key[0][0]] = (call, V, P)

    def ranking_masks(self, records: Sequence[Recording], train: Sequence[np.ndarray]
                      ) -> Sequence[np.ndarray]:
        """The training rows a ranking solve reads: ``train`` cut to each recording's
        :func:`~.screening.ranking_span` (``train`` itself where no recording is cut).
        Memoised on the identities of both, so the cut masks keep theirs (the layout and the
        reduced bases are memoised on them)."""
        key = (tuple(id(r) for r in records), tuple(id(m) for m in train))
        hit = self.ranking.get(key)
        if hit is not None and all(a is b for a, b in zip(hit[0], records, strict=True)) and all(
                a is b for a, b in zip(hit[1], train, strict=True)):
            return hit[2]
        spans = []
        for rec, msk in zip(records, train, strict=True):
            got = self.events.get(id(rec))
            if got is None or got[0] is not rec:
                got = (rec, event_starts(rec.u))
                self.events[id(rec)] = got
            spans.append(ranking_span(rec, msk, got[1]))
        out: Sequence[np.ndarray] = train
        if any(m < rec.n_samples and msk[m:].any()
               for rec, m, msk in zip(records, spans, train, strict=True)):
            cut = []
            for m, msk in zip(spans, train, strict=True):
                c = msk.copy()
                c[m:] = False
                cut.append(c)
            out = cut
        if len(self.ranking) >= 16:
            self.ranking.pop(next(iter(self.ranking)))
        self.ranking[key] = (list(records), list(train), out)
        return out

    def layout(self, records: Sequence[Recording], train: Sequence[np.ndarray],
               rss_only: bool) -> tuple:
        """The solved rows of :func:`~.structure.fit_structure` and what depends only on
        them: ``(rows, sel, ends, upto, ys, ylo, yhi, center, half, dts)``. Deterministic in
        the recordings (read-only arrays) and the training masks, so memoised on the
        identities of both (the entry keeps them alive, so those identities cannot be reused
        meanwhile)."""
        key = (tuple(id(r) for r in records), tuple(id(m) for m in train), rss_only)
        hit = self.rows.get(key)
        if hit is not None and all(a is b for a, b in zip(hit[0], records, strict=True)) and all(
                a is b for a, b in zip(hit[1], train, strict=True)):
            return hit[2]
        # rows solved on: every k-th training row, about RANKING_ROWS for the rss_only fast
        # path and FULL_FIT_ROWS for a full fit (neighbouring samples are nearly redundant);
        # every signal is formed only up to the last of them (the dynamics are causal)
        n_tr = sum(int(m.sum()) for m in train)
        step = max(1, n_tr // (RANKING_ROWS if rss_only else FULL_FIT_ROWS))
        idx_all = [np.flatnonzero(m) for m in train]
        rows = [idx[::step] for idx in idx_all]
        ends = [int(idx[-1]) + 1 if idx.size else 0 for idx in rows]
        # the reduced basis is taken on every training row: the bank reaches the last of them
        upto = [int(idx[-1]) + 1 if idx.size else 0 for idx in idx_all]
        ys = np.concatenate([rec.y[idx] for rec, idx in zip(records, rows, strict=True)])
        ylo = min(float(rec.y[m].min()) for rec, m in zip(records, train, strict=True)
                  if m.any())
        yhi = max(float(rec.y[m].max()) for rec, m in zip(records, train, strict=True)
                  if m.any())
        center, half = 0.5 * (ylo + yhi), max(0.5 * (yhi - ylo), 1e-12)
        dts = [rec.dt for rec in records]
        sel = [row_selector(idx) for idx in rows]
        out = (rows, sel, ends, upto, ys, ylo, yhi, center, half, dts)
        if len(self.rows) >= 8:
            self.rows.pop(next(iter(self.rows)))
        self.rows[key] = (list(records), list(train), out)
        return out

    def basis(self, banks: Sequence[np.ndarray], train: Sequence[np.ndarray], key: Any
              ) -> np.ndarray:
        V = recent(self.v, key)
        if V is None:
            V = reduced_basis(banks, train)
            if len(self.v) >= 64:
                self.v.pop(next(iter(self.v)))
            self.v[key] = V
        return V

    def has_bank(self, k: int, r: np.ndarray, hist: tuple, shape: tuple = (),
                 beta: float | None = None) -> bool:
        """Whether the play bank of recording ``k`` is in the cache (rate-independent plays,
        or of rate parameter ``beta``)."""
        return (k, hist, beta, r.size, float(r[-1]), shape) in self.d

    def bank(self, k: int, rec: Recording, r: np.ndarray, hist: tuple, beta: float | None,
             shape: tuple = (), upto: int | None = None, bouc_wen: tuple = ()) -> np.ndarray:
        """``[w, plays(w)]`` of recording ``k`` from the virtual history ``hist``, ``(N, n + 1)``;
        ``w`` is the input through the loop shape ``shape`` (the input itself without one);
        a stop base with a slip force by direction has each row times its gain
        (:func:`~.shapes.output_gains`: the bank of the force before the gain, times it).
        With ``bouc_wen`` elements (a Bouc-Wen base), :func:`~core.diagnosis.bases.bouc_wen_bank`
        instead.

        With ``upto``, only the first ``upto`` rows are needed: a bank not in the cache is then
        computed that far and not stored (a search over histories meets each one once).
        """
        if bouc_wen:
            return self._bouc_wen_bank(k, rec, hist, shape, bouc_wen, upto)
        key = (k, hist, beta, r.size, float(r[-1]), shape)
        B = self.budget.get(self.d, key)
        if B is None:
            if upto is None:
                self.budget.make_room(8.0 * rec.n_samples * (r.size + 1))
            u = apply_shape(shape, rec.u if upto is None else rec.u[:upto])
            z0 = play_bank(apply_shape(shape, hist), r)[1] if hist else np.zeros(r.size)
            if beta is None:
                # [w, plays] in one pass: a play of threshold 0 outputs its input exactly
                B = play_bank(u, np.r_[0.0, r], np.r_[0.0, z0])[0]
            else:
                B = np.column_stack((u, rd_play_bank(u, r, beta, rec.dt, z0)[0]))
            g = output_gains(shape, rec.u if upto is None else rec.u[:upto])
            if g is not None:  # a stop base's slip force by direction: rows times its gain
                B *= g[:, None]
            if upto is not None:
                return B
            self.budget.put(self.d, key, B, B.nbytes, BANK, count=6)
        return B

    def bank_rows(self, k: int, rec: Recording, r: np.ndarray, hist: tuple, beta: float | None,
                  shape: tuple, idx: np.ndarray, bouc_wen: tuple = ()) -> np.ndarray:
        """Rows ``idx`` (increasing) of :meth:`bank`, ``(idx.size, n + 1)``: read from the
        bank, cached as :meth:`bank` does, when it is there or fits the cache's budget (or
        is not a bank of rate-independent plays), else the plays run along the input
        storing only those rows (:func:`play_rows`, the same numbers), so a few thousand
        sampled rows do not form ``(N, n + 1)``; a stop base with a slip force by direction
        (rows times their gain, :meth:`bank`) always reads the bank."""
        fits = self.budget.fits(8.0 * rec.n_samples * (r.size + 1))
        if (beta is not None or bouc_wen or fits or self.has_bank(k, r, hist, shape)
                or signed_ratio(shape) != 1.0):
            return self.bank(k, rec, r, hist, beta, shape, bouc_wen=bouc_wen)[idx]
        w = np.ascontiguousarray(apply_shape(shape, rec.u), dtype=np.float64)
        z0 = play_bank(apply_shape(shape, hist), r)[1] if hist else np.zeros(r.size)
        rows = np.asarray(idx, dtype=np.int64)
        return play_rows(w, np.r_[0.0, r], np.r_[0.0, z0], rows,
                          np.empty((rows.size, r.size + 1)))

    def _bouc_wen_bank(self, k: int, rec: Recording, hist: tuple, shape: tuple,
                       elements: tuple, upto: int | None) -> np.ndarray:
        """The bank of a Bouc-Wen or Menegotto-Pinto base
        (:func:`core.diagnosis.bases.element_bank`), always
        computed over the whole recording and memoised apart from the play banks (its RK4
        elements cost some hundred times a play: a search met each one again and again).
        Banks without a virtual history are kept; those of a history search within the cache
        budget (rank :data:`~.cache_budget.FIT`: they cost about what a fit does), least
        recently used first out."""
        key = (k, hist, shape, elements, rec.n_samples, float(rec.u[-1]))
        B = self.budget.get(self.bw, key)
        if B is None:
            B = element_bank(apply_shape(shape, rec.u), elements,
                              apply_shape(shape, hist) if hist else None)
            if hist:
                self.budget.put(self.bw, key, B, B.nbytes, FIT)
            else:
                self.bw[key] = B
        return B if upto is None else B[:upto]

    def levelled(self, k: int, B: np.ndarray, s: Structure) -> np.ndarray:
        """The bank ``B`` ``(N, n + 1)`` of recording ``k`` split into the level segments of
        ``s.levels`` (:func:`core.preisach.level_segments`), ``(N, (n + 1) m)``, column
        ``i m + j`` = segment ``j`` of play ``i``; memoised."""
        key = (k, s.history[k], s.beta_s, len(s.thresholds), float(s.thresholds[-1]),
               s.shape, s.levels, B.shape[0])
        L = self.budget.get(self.lv, key)
        if L is None:
            self.budget.make_room(B.nbytes * (len(s.levels) + 1))
            L = split_levels(B, s.levels)
            # kept apart from the play banks (a search over one recording's history meets
            # the other recordings' levelled banks again and again)
            self.budget.put(self.lv, key, L, L.nbytes, DERIVED, count=8)
        return L


def split_levels(B: np.ndarray, levels: tuple) -> np.ndarray:
    """Rows of a play bank ``B`` ``(N, n + 1)`` split into the level segments of ``levels``
    (:func:`core.preisach.level_segments`), ``(N, (n + 1) m)``, column ``i m + j`` = segment
    ``j`` of play ``i``; ``B`` itself without levels (a PI base). Row by row, so a bank
    streamed in blocks is split block by block to the same numbers."""
    if not levels:
        return B
    return level_segments(B.reshape(-1), levels).reshape(B.shape[0],
                                                         B.shape[1] * (len(levels) + 1))


def recent(d: dict, key: Any) -> Any:
    """``d.get(key)``, moving a hit to the end: the caches evict their oldest entry first,
    so this makes them least-recently-used (a search over one recording's history must
    not evict the other recordings' banks, which every trial reads again)."""
    v = d.pop(key, None)
    if v is not None:
        d[key] = v
    return v


def basis_rows(m: np.ndarray) -> np.ndarray:
    """The training rows (mask ``m``) the reduced basis is taken on: about 2000."""
    idx = np.flatnonzero(m)
    return idx[:: max(1, idx.size // 2000)]


def reduced_basis(banks: Sequence[np.ndarray], train: Sequence[np.ndarray]) -> np.ndarray:
    # (a strided view where the rows are evenly spaced: no gather before the concatenation)
    return basis_of(np.concatenate([B[row_selector(basis_rows(m))]
                                     for B, m in zip(banks, train, strict=True)]))


def basis_of(A: np.ndarray) -> np.ndarray:
    """Leading right-singular directions (at most 24) of the column-scaled rows ``A``."""
    # the Gram of the column-scaled rows, scaled after the product (one pass over A)
    G = A.T @ A
    scale = 1.0 / np.sqrt(np.diag(G) + 1e-300)
    ev, vec = np.linalg.eigh(scale[:, None] * G * scale[None, :])
    ev, vec = ev[::-1], vec[:, ::-1]
    q = int(min(24, max(1, np.sum(ev > 1e-10 * ev[0]))))
    return (scale[:, None] * vec[:, :q]).copy()
