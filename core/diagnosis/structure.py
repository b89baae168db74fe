"""Model structures (PI + a set of effects) and their separable least-squares fit.

A :class:`Structure` says which effects are switched on and holds their few nonlinear
parameters (delay, time constants, ω_n, ζ, β, virtual extrema) and the settings of the static
terms, by effect name. For fixed nonlinear parameters every structure is linear in its
weights: the play weights ``p0, p_i >= 0`` and the weights of the static terms (the bias or
offsets, creep ``c_j >= 0``, asymmetry and drift coefficients), because linear dynamics
after the PI commute with the weighted sum. Each static term brings its own columns, bounds,
coefficients and stage (:class:`~core.diagnosis.registry.StaticTerm`); this module loops
over the registered ones and names none. :func:`fit_structure` solves that
constrained linear problem on the training rows (:func:`core.fitting.gram.solve_constrained` on the
augmented Gram matrix, or on its QR factor when that is ill conditioned) and builds the exact
:class:`~core.base.Chain`; predictions always come from simulating that chain, so the numbers
the diagnosis reports are the numbers ``hyst simulate`` reproduces.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Iterator, Sequence
from dataclasses import MISSING, dataclass, field, fields, replace
from typing import Any, Literal, NamedTuple, overload

import numpy as np

from .._typing import Float1D
from ..base import Chain, Model
from ..fitting.gram import COND_LIMIT, r_factor, solve_constrained
from ..kernels import njit
from ..operators import play_bank
from ..pi import PIModel
from ..preisach import PreisachModel, RateDependentPreisach, level_segments
from ..recordings import Recording
from ..stages import InitialMemory, RateDependentPI, discretised_tf, rd_play_bank
from ..validation import filled
from .bases import bouc_wen_bank, bouc_wen_model, initial_state, stop_model
from .cache_budget import BANK, DERIVED, FIT, CacheBudget
from .grid import baseline_thresholds
from .registry import (
    EFFECTS,
    StaticTerm,
    TermFit,
    TermRows,
    dynamics_of,
    static_terms,
    term_of,
)
from .shapes import apply_shape, gap_stage_of, hysteresis_model, loop_shape, shape_effects

__all__ = ["Fit", "PIStageOutputs", "Structure", "baseline_thresholds", "build_model",
           "dynamics_stages", "fit_structure", "legendre_columns", "pack_dynamics"]


def dynamics_stages(dyn: tuple) -> list[tuple[str, tuple[float, ...]]]:
    """The output dynamics stages of a :attr:`Structure.dynamics` tuple, in series order:
    ``[(name, values), ...]`` (each name followed by as many values as its registered
    :attr:`~core.diagnosis.registry.OutputDynamics.params`).

    Raises
    ------
    ValueError
        For a name that is not a registered output dynamics stage.
    """
    out: list[tuple[str, tuple[float, ...]]] = []
    i = 0
    while i < len(dyn):
        spec = EFFECTS[dyn[i]].dynamics if dyn[i] in EFFECTS else None
        if spec is None:
            raise ValueError(f"unknown dynamics {dyn[i]!r}")
        n = len(spec.params)
        out.append((dyn[i], tuple(dyn[i + 1 : i + 1 + n])))
        i += 1 + n
    return out


def pack_dynamics(names: Sequence[str], values: Sequence[float], dt: float | None = None
                  ) -> tuple | None:
    """The :attr:`Structure.dynamics` tuple of the output stages ``names`` in series with
    their parameter ``values`` concatenated in that order (the inverse of
    :func:`dynamics_stages`); ``None`` when ``dt`` (s) is given and the values of a stage are
    not valid at that sample period
    (:attr:`~core.diagnosis.registry.OutputDynamics.valid`)."""
    out: list = []
    o = 0
    for n in names:
        spec = EFFECTS[n].dynamics
        assert spec is not None
        v = tuple(float(a) for a in values[o : o + len(spec.params)])
        if dt is not None and not spec.valid(v, dt):
            return None
        out += [n, *v]
        o += len(v)
    return tuple(out)


@dataclass(frozen=True)
class Structure:
    """Which effects are on, with their nonlinear parameters.

    Attributes
    ----------
    thresholds : tuple of float
        Play thresholds (input units).
    history : tuple
        Per recording: virtual input extrema before the record (``()`` = none).
    beta_s : float or None
        Rate coefficient of the rate-dependent PI (``None`` = rate-independent).
    terms : tuple of (str, object)
        Settings of the static terms switched on, ``(effect name, settings)`` sorted by name
        (:class:`~core.diagnosis.registry.StaticTerm`; e.g. ``("creep", (0.01, 0.1))`` for
        a creep bank of those time constants, ``("drift", 2)`` for a Legendre drift of
        degree 2 per recording); read with :meth:`term`, set with :meth:`with_term`.
    dynamics : tuple
        ``()``, ``("delay", τ_d)``, ``("lag", τ)`` or ``("resonance", f_n, ζ)``; two stages
        in series are their tuples concatenated (``("lag", τ, "resonance", f_n, ζ)``,
        :func:`dynamics_stages`; pairs the registry allows,
        :attr:`~core.diagnosis.registry.OutputDynamics.combines_with`).
    free_weights : bool
        Play weights of either sign (``p0 >= 0`` only): saturating loops such as friction need
        negative weights; by default ``p_i >= 0`` (hardening loops, invertible).
    shape : tuple
        Loop-shape input maps the plays run on (:mod:`core.diagnosis.shapes`; ``()`` =
        classical PI); ``thresholds`` are then in the units of the mapped input, and an
        initial memory is the mapped history (the model's ``state0``). A stop-operator base
        (clockwise loops, :mod:`core.diagnosis.bases`) has its input map first
        (``("gap", ...)``, the input behind its backlash gap) and its weights solved as
        Maxwell-slip stiffnesses ``k >= eps``, ``w_i >= 0``; the weights kept are the play
        frame's (``p0 = k + sum w_i``, ``p_i = -w_i``).
    levels : tuple of float
        Interior level knots of a Preisach base (:class:`~core.preisach.PreisachModel`,
        level-dependent memory, E10): each play output (the input itself for the
        reversible part) is split into level segments with weights of their own, so the
        relay density varies along the relay centre; ``()`` = a PI base.
    level_smooth : float
        Smoothness penalty of a Preisach base: squared differences of the weights of
        neighbouring level segments of each play, relative to the mean energy of the
        hysteresis columns (0 = none).
    bouc_wen : tuple of (float, float, float)
        Elements ``(beta, gamma, n)`` of a Bouc-Wen base (:mod:`core.diagnosis.bases`):
        the hysteresis columns come from the elements' variables ``z_j`` instead of plays
        (nonnegative weights: an invertible hardening loop; either sign with
        ``free_weights``), and ``thresholds`` hold each element's saturation
        ``(beta + gamma)^(-1/n)``; ``()`` = a PI or Preisach base.
    """

    thresholds: tuple[float, ...]
    history: tuple[tuple[float, ...], ...]
    beta_s: float | None = None
    terms: tuple[tuple[str, Any], ...] = ()
    dynamics: tuple = ()
    free_weights: bool = False
    shape: tuple = ()
    levels: tuple[float, ...] = ()
    level_smooth: float = 0.0
    bouc_wen: tuple[tuple[float, float, float], ...] = ()

    @property
    def base_kind(self) -> str:
        """The base hysteresis: ``"bouc-wen"``, ``"preisach"`` (level-dependent memory),
        ``"stop-pi"`` (stop operators behind a backlash gap) or ``"pi"``."""
        return ("bouc-wen" if self.bouc_wen else "preisach" if self.levels
                else "stop-pi" if self.stop else "pi")

    @property
    def stop(self) -> bool:
        """A stop-operator base (its input map first in :attr:`shape`)."""
        return gap_stage_of(self.shape) is not None

    @property
    def effects(self) -> list[str]:
        """Names of the effects switched on, in pipeline order (loop shapes first, then by
        the registry's :attr:`~core.diagnosis.registry.DiagnosableEffect.stage_order`)."""
        on = [e for e in EFFECTS.values() if e.structure_field is not None and self._on(e)]
        return shape_effects(self.shape) + [e.name for e in sorted(on, key=lambda e: e.stage_order)]

    def term(self, name: str) -> Any:
        """The settings of static term ``name`` (its
        :attr:`~core.diagnosis.registry.StaticTerm.off` settings when not switched on)."""
        for n, v in self.terms:
            if n == name:
                return v
        t = EFFECTS[name].term
        if t is None:
            raise ValueError(f"effect {name!r} is not a static term")
        return t.off

    def with_term(self, name: str, settings: Any) -> Structure:
        """Copy with static term ``name`` set to ``settings`` (switched off by its
        :attr:`~core.diagnosis.registry.StaticTerm.off` settings)."""
        t = EFFECTS[name].term
        if t is None:
            raise ValueError(f"effect {name!r} is not a static term")
        kept = [(n, v) for n, v in self.terms if n != name]
        if settings != t.off:
            kept.append((name, settings))
        return replace(self, terms=tuple(sorted(kept, key=lambda nv: nv[0])))

    def without_terms(self, through_dynamics: bool) -> Structure:
        """Copy without the static terms that act before (``True``) or after (``False``)
        the output dynamics."""
        return replace(self, terms=tuple(
            (n, v) for n, v in self.terms
            if term_of(n).through_dynamics != through_dynamics))

    def _terms_on(self) -> list[StaticTerm]:
        return [term_of(n) for n, _ in self.terms]

    @property
    def reads_output(self) -> bool:
        """A static term reads the PI-stage output (its columns are bilinear in the play
        weights: a fit refreshes them from a previous one)."""
        return any(t.through_dynamics for t in self._terms_on())

    @property
    def needs_sample_spacing(self) -> bool:
        """A static term's columns depend on the sample spacing (a filter)."""
        return any(t.sample_spacing for t in self._terms_on())

    @property
    def bank_width(self) -> int:
        """Weights of the static terms whose width grows with their settings (a lag bank)."""
        return sum(t.width(v, 1) for (_, v), t in zip(self.terms, self._terms_on(),
                                                      strict=True) if t.bank)

    def recording_levels(self) -> tuple[tuple[str, Any], ...]:
        """Settings of the per-recording terms switched on (levels an unseen recording
        cannot know: offsets, drifts)."""
        return tuple((n, v) for n, v in self.terms
                     if term_of(n).per_recording)

    @property
    def own_level(self) -> int:
        """Legendre degree in time of the level a left-out recording is given of its own
        (:func:`core.diagnosis.between.left_out_residual`): the largest
        :attr:`~core.diagnosis.registry.StaticTerm.level_degree` of the per-recording terms
        switched on, 0 (a constant) without them."""
        degrees = []
        for n, v in self.recording_levels():
            level = term_of(n).level_degree
            if level is not None:
                degrees.append(level(v))
        return max(degrees, default=0)

    def _on(self, e: Any) -> bool:
        """Whether registered effect ``e`` is switched on: its field differs from the
        baseline's (an output dynamics stage: the stage is ``e`` itself; a static term: it
        has settings in :attr:`terms`)."""
        if e.term is not None:
            return any(n == e.name for n, _ in self.terms)
        v = getattr(self, e.structure_field)
        if e.dynamics is not None:
            return any(n == e.name for n, _ in dynamics_stages(v))
        if e.structure_field == "history":
            return any(v)
        return v != _BASELINE_FIELDS[e.structure_field]

    def with_(self, **kw: Any) -> Structure:
        """Copy with some fields replaced."""
        return replace(self, **kw)

    def without(self, name: str, base: Structure) -> Structure:
        """Copy with effect ``name`` switched off (its field, the registry's
        :attr:`~core.diagnosis.registry.DiagnosableEffect.structure_field`, as in ``base``,
        the structure it was added to); loop shapes are part of the hysteresis and stay. One
        of two output stages in series is taken out alone (the other stays)."""
        f = EFFECTS[name].structure_field if name in EFFECTS else None
        if f is None:
            raise ValueError(f"effect {name!r} cannot be switched off in a structure")
        if EFFECTS[name].term is not None:
            return self.with_term(name, base.term(name))
        if EFFECTS[name].dynamics is not None and len(dynamics_stages(self.dynamics)) > 1:
            # one of two stages in series: the other stays
            return replace(self, dynamics=tuple(
                x for n, v in dynamics_stages(self.dynamics) if n != name for x in (n, *v)))
        return replace(self, **{f: getattr(base, f)})


#: The value of each optional :class:`Structure` field with nothing switched on.
_BASELINE_FIELDS = {f.name: f.default for f in fields(Structure)
                    if f.default is not MISSING}


@dataclass
class Fit:
    """A fitted structure: weights, per-recording models and exact predictions.

    Attributes
    ----------
    terms : dict
        Coefficients of every static term with columns, by effect name (what the term's
        :attr:`~core.diagnosis.registry.StaticTerm.coefficients` makes of its weights: the
        common bias is the offset term's, switched off).
    """

    structure: Structure
    p0: float
    weights: Float1D
    terms: dict[str, Any]
    models: list[Model]
    pred: list[Float1D]
    x_pi: Sequence[Float1D]  # PI-stage outputs (before the output map and dynamics)
    train_rss: float
    n_train: int
    cov_scale: float = 1.0
    extras: dict[str, Any] = field(default_factory=dict)

    def residuals(self, records: Sequence[Recording]) -> list[Float1D]:
        """Measured minus simulated output per recording."""
        return [r.y - p for r, p in zip(records, self.pred, strict=True)]


class PIStageOutputs(Sequence):
    """The PI-stage outputs of a fit per recording, ``bank @ weights``, formed on first use.

    Most fits never need them (only the bilinear creep and asymmetry regressors and the
    look-alike evidence read them), and each is a pass over an ``(N, n + 1)`` play bank, so
    they are computed when first read. The object holds no bank: ``source(k, w)`` forms
    recording ``k``'s output (:func:`_stage_output`: the plays streamed in row blocks, or the
    cached bank times ``w``), so a memoised fit costs its outputs, not its banks.
    :meth:`resolve` forms them at once (a result that outlives the diagnosis should not
    hold the source's cache).
    """

    def __init__(self, source: Any, n: int, w: np.ndarray) -> None:
        self._source = source
        self._w = w
        self._n = n
        self._x: list[Float1D] | None = None
        self._lock = threading.Lock()

    def resolve(self) -> list[Float1D]:
        """The outputs, formed now if not yet (thread-safe)."""
        x = self._x
        if x is None:
            with self._lock:
                if self._x is None:
                    self._x = [self._source(k, self._w) for k in range(self._n)]
                    self._source = None
                x = self._x
        return x

    def __getitem__(self, i):
        return self.resolve()[i]

    def __iter__(self) -> Iterator[Float1D]:
        return iter(self.resolve())

    def __len__(self) -> int:
        return self._n

    def __reduce__(self) -> tuple:
        # pickled / copied as the plain list of outputs (never the source or the lock): a
        # worker process sends its diagnosis back pickled
        return (list, (self.resolve(),))


class _Cache:
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
        the product is then formed by :func:`_bank_rows_times` where the input turns rarely.
        """
        key = (key, id(V))
        hit = self.budget.get(self.p, key)
        if hit is not None and hit[0] is V:
            if hit[2] <= start:
                return hit[1][start - hit[2]:]
            start0 = 0
        else:
            start0 = start
        P = None
        if r is not None and B.shape[0] > start0:
            P = _bank_rows_times(B, V, r, np.arange(start0, B.shape[0]))
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
        self.budget.put(self.p, key, (V, P, start0), P.nbytes, DERIVED, count=16)
        return P[start - start0:]

    def layout(self, records: Sequence[Recording], train: Sequence[np.ndarray],
               rss_only: bool) -> tuple:
        """The solved rows of :func:`fit_structure` and what depends only on them: ``(rows,
        sel, ends, upto, ys, ylo, yhi, center, half, dts)``. Deterministic in the recordings
        (read-only arrays) and the training masks, so memoised on the identities of both
        (the entry keeps them alive, so those identities cannot be reused meanwhile)."""
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
        sel = [_row_selector(idx) for idx in rows]
        out = (rows, sel, ends, upto, ys, ylo, yhi, center, half, dts)
        if len(self.rows) >= 8:
            self.rows.pop(next(iter(self.rows)))
        self.rows[key] = (list(records), list(train), out)
        return out

    def basis(self, banks: list[np.ndarray], train: Sequence[np.ndarray], key: Any) -> np.ndarray:
        V = _recent(self.v, key)
        if V is None:
            V = _basis(banks, train)
            if len(self.v) >= 64:
                self.v.pop(next(iter(self.v)))
            self.v[key] = V
        return V

    def has_bank(self, k: int, r: np.ndarray, hist: tuple, shape: tuple = ()) -> bool:
        """Whether the rate-independent play bank of recording ``k`` is in the cache."""
        return (k, hist, None, r.size, float(r[-1]), shape) in self.d

    def bank(self, k: int, rec: Recording, r: np.ndarray, hist: tuple, beta: float | None,
             shape: tuple = (), upto: int | None = None, bouc_wen: tuple = ()) -> np.ndarray:
        """``[w, plays(w)]`` of recording ``k`` from the virtual history ``hist``, ``(N, n + 1)``;
        ``w`` is the input through the loop shape ``shape`` (the input itself without one).
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
            if upto is not None:
                return B
            self.budget.put(self.d, key, B, B.nbytes, BANK, count=6)
        return B

    def bank_rows(self, k: int, rec: Recording, r: np.ndarray, hist: tuple, beta: float | None,
                  shape: tuple, idx: np.ndarray, bouc_wen: tuple = ()) -> np.ndarray:
        """Rows ``idx`` (increasing) of :meth:`bank`, ``(idx.size, n + 1)``: read from the
        bank, cached as :meth:`bank` does, when it is there or fits the cache's budget (or
        is not a bank of rate-independent plays), else the plays run along the input
        storing only those rows (:func:`_play_rows`, the same numbers), so a few thousand
        sampled rows do not form ``(N, n + 1)``."""
        fits = self.budget.fits(8.0 * rec.n_samples * (r.size + 1))
        if beta is not None or bouc_wen or fits or self.has_bank(k, r, hist, shape):
            return self.bank(k, rec, r, hist, beta, shape, bouc_wen=bouc_wen)[idx]
        w = np.ascontiguousarray(apply_shape(shape, rec.u), dtype=np.float64)
        z0 = play_bank(apply_shape(shape, hist), r)[1] if hist else np.zeros(r.size)
        rows = np.asarray(idx, dtype=np.int64)
        return _play_rows(w, np.r_[0.0, r], np.r_[0.0, z0], rows,
                          np.empty((rows.size, r.size + 1)))

    def _bouc_wen_bank(self, k: int, rec: Recording, hist: tuple, shape: tuple,
                       elements: tuple, upto: int | None) -> np.ndarray:
        """The bank of a Bouc-Wen base (:func:`core.diagnosis.bases.bouc_wen_bank`), always
        computed over the whole recording and memoised apart from the play banks (its RK4
        elements cost some hundred times a play: a search met each one again and again).
        Banks without a virtual history are kept; those of a history search within the cache
        budget (rank :data:`~.cache_budget.FIT`: they cost about what a fit does), least
        recently used first out."""
        key = (k, hist, shape, elements, rec.n_samples, float(rec.u[-1]))
        B = self.budget.get(self.bw, key)
        if B is None:
            B = bouc_wen_bank(apply_shape(shape, rec.u), elements,
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
            L = _segments(B, s.levels)
            # kept apart from the play banks (a search over one recording's history meets
            # the other recordings' levelled banks again and again)
            self.budget.put(self.lv, key, L, L.nbytes, DERIVED, count=8)
        return L


def _segments(B: np.ndarray, levels: tuple) -> np.ndarray:
    """Rows of a play bank ``B`` ``(N, n + 1)`` split into the level segments of ``levels``
    (:func:`core.preisach.level_segments`), ``(N, (n + 1) m)``, column ``i m + j`` = segment
    ``j`` of play ``i``; ``B`` itself without levels (a PI base). Row by row, so a bank
    streamed in blocks is split block by block to the same numbers."""
    if not levels:
        return B
    return level_segments(B.reshape(-1), levels).reshape(B.shape[0],
                                                         B.shape[1] * (len(levels) + 1))


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


#: Rows of a block of the play bank streamed by :func:`_stage_output` (0.2 MB per play; 50,000
#: held 70 MB of a resolution refit's bank at the 100,000-sample diagnosis's peak).
STREAM_ROWS = 25_000


def _recent(d: dict, key: Any) -> Any:
    """``d.get(key)``, moving a hit to the end: the caches evict their oldest entry first,
    so this makes them least-recently-used (a search over one recording's history must
    not evict the other recordings' banks, which every trial reads again)."""
    v = d.pop(key, None)
    if v is not None:
        d[key] = v
    return v


def _row_selector(idx: np.ndarray) -> slice | np.ndarray:
    """Index ``B[sel]`` equal to ``B[idx]`` for increasing indices ``idx``: a slice (a strided
    view, no gather) when they are evenly spaced, as in a single training window."""
    if idx.size > 1:
        d = np.diff(idx)
        if d[0] > 0 and np.all(d == d[0]):
            return slice(int(idx[0]), int(idx[-1]) + 1, int(d[0]))
    return idx


def _basis_rows(m: np.ndarray) -> np.ndarray:
    """The training rows (mask ``m``) the reduced basis is taken on: about 2000."""
    idx = np.flatnonzero(m)
    return idx[:: max(1, idx.size // 2000)]


def _basis(banks: list[np.ndarray], train: Sequence[np.ndarray]) -> np.ndarray:
    # (a strided view where the rows are evenly spaced: no gather before the concatenation)
    return _basis_of(np.concatenate([B[_row_selector(_basis_rows(m))]
                                     for B, m in zip(banks, train, strict=True)]))


def _basis_of(A: np.ndarray) -> np.ndarray:
    """Leading right-singular directions (at most 24) of the column-scaled rows ``A``."""
    # the Gram of the column-scaled rows, scaled after the product (one pass over A)
    G = A.T @ A
    scale = 1.0 / np.sqrt(np.diag(G) + 1e-300)
    ev, vec = np.linalg.eigh(scale[:, None] * G * scale[None, :])
    ev, vec = ev[::-1], vec[:, ::-1]
    q = int(min(24, max(1, np.sum(ev > 1e-10 * ev[0]))))
    return (scale[:, None] * vec[:, :q]).copy()


@njit(cache=True, nogil=True)
def _iir_rows(b, a, zi, x, rows, out):  # pragma: no cover - compiled
    """Direct-form-II-transposed filter ``b/a`` (order 1 or 2) of the columns of ``x``.

    ``x`` is row-major ``(N, m)``, the filter starts in the steady state of ``x[0]``
    (state ``zi * x[0]``, as :func:`core.stages.foh_filter`), and only the increasing rows
    ``rows`` are written to ``out`` ``(rows.size, m)``. Time is the outer loop so that the
    ``m`` independent recursions vectorise; the operation order is scipy's ``lfilter``.
    """
    m = x.shape[1]
    order = a.size - 1
    b0 = b[0]
    b1 = b[1]
    a1 = a[1]
    b2 = b[2] if order == 2 else 0.0
    a2 = a[2] if order == 2 else 0.0
    z0 = np.empty(m)
    z1 = np.zeros(m)
    for j in range(m):
        z0[j] = zi[0] * x[0, j]
        if order == 2:
            z1[j] = zi[1] * x[0, j]
    k = 0
    for i in range(rows[-1] + 1 if rows.size else 0):
        take = rows[k] == i
        for j in range(m):
            xi = x[i, j]
            yi = b0 * xi + z0[j]
            if order == 2:
                z0[j] = z1[j] + xi * b1 - yi * a1
                z1[j] = xi * b2 - yi * a2
            else:
                z0[j] = xi * b1 - yi * a1
            if take:
                out[k, j] = yi
        if take:
            k += 1
    return out


@njit(cache=True, nogil=True)
def _play_rows(u, r, z, rows, out):  # pragma: no cover - compiled
    """Rows ``rows`` (increasing) of the play bank of thresholds ``r`` on input ``u`` from the
    state ``z`` (updated in place), without storing the others: the update of
    :func:`core.kernels.play_matrix`, so the same numbers."""
    n = r.size
    k = 0
    for i in range(rows[-1] + 1 if rows.size else 0):
        ui = u[i]
        for j in range(n):
            lo = ui - r[j]
            hi = ui + r[j]
            zj = z[j]
            if zj > hi:
                zj = hi
            if zj < lo:
                zj = lo
            z[j] = zj
        if i == rows[k]:
            for j in range(n):
                out[k, j] = z[j]
            k += 1
    return out


@njit(cache=True, nogil=True)
def _play_projection(w, r, z, V, rows, out):  # pragma: no cover - compiled  # noqa: C901 - the fast paths of one product, each a guarded branch
    """Rows ``rows`` of ``B @ V``, ``B`` the play bank of thresholds ``r`` (``r[0] = 0``: the
    input itself) on input ``w``, without forming ``B`` or the ``(N, n) x (n, q)`` product.

    ``z`` ``(n,)``: the bank's row 0 (the play outputs after ``w[0]``); overwritten.
    On a monotone stretch a play either follows the input (``z_j = w -/+ r_j``) or is
    stuck, so ``B[i] @ V = C + w_i S - R`` with ``C`` the stuck plays' ``z_j V_j``, ``S`` the
    moving plays' ``V_j`` and ``R`` their ``+/- r_j V_j``: a row costs ``O(q)``, and the exact
    play update (:func:`core.kernels.play_matrix`) runs over all plays only at a reversal or
    where a stuck play may start to move (its level is within round-off of the input). The
    sums are rebuilt after ``4 n`` changes, so their round-off stays that of a few sums.
    Writes ``out`` ``(rows.size, q)`` (increasing rows).
    """
    n = r.size
    q = V.shape[1]
    status = np.zeros(n, dtype=np.int8)  # 0 stuck, 1 follows w - r, -1 follows w + r
    C = np.zeros(q)
    S = np.zeros(q)
    R = np.zeros(q)
    for j in range(n):
        for c in range(q):
            C[c] += z[j] * V[j, c]
    n_up = 0  # moving plays with r > 0 by direction
    n_dn = 0
    up_lvl = -np.inf  # the input levels where a stuck play starts to move up / down
    dn_lvl = np.inf
    changes = 4 * n + 1  # force the first exact pass to set the levels
    rmax = 0.0
    for j in range(n):
        rmax = max(rmax, r[j])
    k = 0
    last = rows[-1] if rows.size else -1
    for i in range(last + 1):
        wi = w[i]
        fast = True
        if i > 0:
            tol = 8.0 * 2.220446049250313e-16 * (abs(wi) + rmax)
            wp = w[i - 1]
            fast = wi == wp or (wi > wp and n_dn == 0 and wi < up_lvl - tol) or (
                wi < wp and n_up == 0 and wi > dn_lvl + tol)
            if not fast:
                for j in range(n):
                    lo = wi - r[j]
                    hi = wi + r[j]
                    # (a moving play's state is not stored on the fast rows: it is the
                    # previous input -/+ its threshold, formed as the play update forms it)
                    zj = z[j] if status[j] == 0 else (wp - r[j] if status[j] == 1
                                                      else wp + r[j])
                    if zj > hi:
                        zj = hi
                    if zj < lo:
                        zj = lo
                    st = 1 if zj == lo else (-1 if zj == hi else 0)
                    if st != status[j]:
                        old = status[j]
                        if old == 0:
                            for c in range(q):
                                C[c] -= z[j] * V[j, c]
                        else:
                            for c in range(q):
                                S[c] -= V[j, c]
                                R[c] -= old * r[j] * V[j, c]
                            if r[j] > 0:
                                if old == 1:
                                    n_up -= 1
                                else:
                                    n_dn -= 1
                        if st == 0:
                            for c in range(q):
                                C[c] += zj * V[j, c]
                        else:
                            for c in range(q):
                                S[c] += V[j, c]
                                R[c] += st * r[j] * V[j, c]
                            if r[j] > 0:
                                if st == 1:
                                    n_up += 1
                                else:
                                    n_dn += 1
                        status[j] = st
                        changes += 1
                    z[j] = zj
        if changes > 4 * n:
            # rebuild the sums from the play states (bounds their round-off) and the levels
            for c in range(q):
                C[c] = 0.0
                S[c] = 0.0
                R[c] = 0.0
            for j in range(n):
                if status[j] == 0:
                    for c in range(q):
                        C[c] += z[j] * V[j, c]
                else:
                    for c in range(q):
                        S[c] += V[j, c]
                        R[c] += status[j] * r[j] * V[j, c]
            changes = 0
        if changes == 0 or not fast:
            up_lvl = np.inf
            dn_lvl = -np.inf
            for j in range(n):
                if status[j] == 0:
                    up_lvl = min(up_lvl, z[j] + r[j])
                    dn_lvl = max(dn_lvl, z[j] - r[j])
        if i == rows[k]:
            if i == 0:
                for c in range(q):
                    acc = 0.0
                    for j in range(n):
                        acc += z[j] * V[j, c]
                    out[k, c] = acc
            else:
                for c in range(q):
                    out[k, c] = C[c] + wi * S[c] - R[c]
            k += 1
    return out


def _bank_rows_times(B: np.ndarray, V: np.ndarray, r: np.ndarray, rows: np.ndarray
                     ) -> np.ndarray | None:
    """``(B @ V)[rows]`` for a play bank ``B`` ``(N, n)`` of thresholds ``r`` (``r[0] = 0``,
    column 0 the input) by :func:`_play_projection`, from row ``rows[0]`` on; ``None`` when
    the input turns so often (measurement noise on it) that the product is cheaper."""
    if not rows.size:
        return None
    s0 = int(rows[0])
    w = np.ascontiguousarray(B[s0 : int(rows[-1]) + 1, 0])
    if not _turns_rarely(w, r.size):
        return None
    return _input_rows_times(w, B[s0], V, r, np.asarray(rows, dtype=np.int64) - s0)


def _sampled_banks(cache: _Cache, s: Structure, records: Sequence[Recording],
                   train: Sequence[np.ndarray], rows: list[np.ndarray], upto: list[int],
                   starts: list[int], vkey: Any
                   ) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]] | None:
    """What a ranking solve of rate-independent plays needs of banks not in ``cache``: the
    reduced basis (memoised on ``vkey``), and per recording the bank input (the input through
    the loop shape, up to ``upto``) and the bank row the products start from (``starts``, or
    the first solved row of ``rows`` without dynamics). The plays run along the input storing
    only the basis rows and those (:func:`_play_rows`, the numbers of the full bank). ``None``
    when a bank is in the cache or an input reverses often (the product is then cheaper)."""
    r = np.asarray(s.thresholds)
    r_full = np.r_[0.0, r]
    if any(cache.has_bank(k, r, s.history[k], s.shape) for k in range(len(records))):
        return None
    inputs, row0, samples = [], [], []
    for k, (rec, m, idx) in enumerate(zip(records, train, rows, strict=True)):
        w = apply_shape(s.shape, rec.u[: upto[k]])
        first = (starts[k] if s.dynamics else int(idx[0])) if idx.size else 0
        if idx.size and not _turns_rarely(w[first : int(idx[-1]) + 1], r_full.size):
            return None
        hist = s.history[k]
        z0 = play_bank(apply_shape(s.shape, hist), r)[1] if hist else np.zeros(r.size)
        ib = _basis_rows(m)
        # (the basis rows are increasing: the start row goes in its place)
        at = int(np.searchsorted(ib, first))
        need = (ib if at < ib.size and ib[at] == first else np.insert(ib, at, first)).astype(
            np.int64)
        B = _play_rows(np.ascontiguousarray(w, dtype=np.float64), r_full, np.r_[0.0, z0],
                       need, np.empty((need.size, r_full.size)))
        inputs.append(w)
        row0.append(B[np.searchsorted(need, first)] if need.size else np.zeros(r_full.size))
        samples.append(B[np.searchsorted(need, ib)])
    V = _recent(cache.v, vkey)
    if V is None:
        V = _basis_of(np.concatenate(samples))
        if len(cache.v) >= 64:
            cache.v.pop(next(iter(cache.v)))
        cache.v[vkey] = V
    return V, inputs, row0


def _turns_rarely(w: np.ndarray, n: int) -> bool:
    """Whether the input ``w`` reverses rarely enough (``n`` plays) for
    :func:`_play_projection` to beat the product."""
    d = np.diff(w)
    d = d[d != 0]
    return bool(np.count_nonzero((d[1:] > 0) != (d[:-1] > 0)) * n <= 0.5 * w.size)


def _input_rows_times(w: np.ndarray, z0: np.ndarray, V: np.ndarray, r: np.ndarray,
                      rows: np.ndarray) -> np.ndarray:
    """Rows ``rows`` of ``B @ V``, ``B`` the bank of thresholds ``r`` on input ``w`` whose row 0
    is ``z0`` (:func:`_play_projection`)."""
    out = np.empty((rows.size, V.shape[1]))
    return _play_projection(np.ascontiguousarray(w, dtype=np.float64),
                            np.ascontiguousarray(r, dtype=np.float64),
                            np.array(z0, dtype=np.float64), np.ascontiguousarray(V), rows, out)


@njit(cache=True, nogil=True)
def _delay_rows(x, rows, m, f, out):  # pragma: no cover - compiled
    """Rows ``rows`` of ``x`` delayed by ``m + f`` samples (``0 <= f < 1``), linearly
    interpolated and held at ``x[0]`` before the start:
    ``out[k] = f x[rows[k] - m - 1] + (1 - f) x[rows[k] - m]``."""
    g = 1 - f
    for k in range(rows.size):
        i1 = max(rows[k] - m - 1, 0)
        i2 = max(rows[k] - m, 0)
        for j in range(x.shape[1]):
            out[k, j] = f * x[i1, j] + g * x[i2, j]
    return out


def _dyn_rows(x: np.ndarray, dyn: tuple, dt: float, rows: np.ndarray,
              out: np.ndarray | None = None) -> np.ndarray:
    """Rows ``rows`` (increasing indices) of the columns of ``x`` passed through the
    output dynamics ``dyn`` (delay: linear interpolation; lag, resonance: the first-order-
    hold discretisation of :func:`core.stages.foh_filter`, at rest in the steady state of
    the first sample). ``x`` is ``(N, m)``; written to ``out`` ``(rows.size, m)`` (a new
    array by default), which is returned."""
    if out is None:
        out = np.empty((rows.size, x.shape[1]))
    if not dyn or not rows.size:
        out[...] = x[_row_selector(rows)]  # (a strided view for evenly spaced rows: no gather)
        return out
    stages = dynamics_stages(dyn)
    if len(stages) > 1:
        # stages in series: every one but the last on all rows up to the last needed
        every = np.arange(int(rows[-1]) + 1)
        xs = np.ascontiguousarray(x[: every.size], dtype=np.float64)
        for name, v in stages[:-1]:
            xs = _dyn_rows(xs, (name, *v), dt, every)
        name, v = stages[-1]
        return _dyn_rows(xs, (name, *v), dt, rows, out=out)
    stage = EFFECTS[dyn[0]].dynamics
    if stage is None:
        raise ValueError(f"unknown dynamics {dyn[0]!r}")
    xc = np.ascontiguousarray(x, dtype=np.float64)
    if stage.transfer is None:  # a pure (fractional) transport delay
        D = dyn[1] / dt
        m = int(np.floor(D + 1e-12))
        return _delay_rows(xc, np.asarray(rows, dtype=np.int64), m, D - m, out)
    num, den = stage.transfer(tuple(dyn[1:]))
    b, a, zi = discretised_tf(num, den, dt)
    return _iir_rows(b, a, zi, xc, np.asarray(rows, dtype=np.int64), out)


#: Decay a filtered start transient must reach before the first row :func:`_filter_start`
#: lets through: far below the round-off of double precision, so the rows are those of the
#: filter run from the first sample (to round-off).
WARM_DECAY = 1e-30


def _filter_start(dyn: tuple, dt: float, first: int) -> int:
    """First sample from which the output dynamics ``dyn`` must run (started in the steady
    state of that sample, as :func:`_dyn_rows` does) for rows ``>= first`` to equal, to
    round-off, those of the dynamics run from sample 0.

    A delay reads back a fixed number of samples (exact); a lag or resonance forgets its
    start state geometrically with its slowest discrete pole ``rho``: the start is taken
    ``log(WARM_DECAY) / log(rho)`` samples (plus the filter order) before ``first``, where
    the start transient has decayed below :data:`WARM_DECAY` of the signal. 0 when the
    dynamics never forget (``rho >= 1``) or that reaches back past the first sample.
    """
    if not dyn or first <= 0:
        return 0
    # stages in series: their warm-ups add up
    warm = 0
    for name, vals in dynamics_stages(dyn):
        if dynamics_of(name).transfer is None:
            warm += int(np.floor(vals[0] / dt + 1e-12)) + 1  # a (fractional) transport delay
            continue
        w = _filter_warmup((name, *vals), float(dt))
        if w < 0:
            return 0
        warm += w
    return max(0, first - warm)


@functools.lru_cache(maxsize=1024)
def _filter_warmup(dyn: tuple, dt: float) -> int:
    """Samples the filtered dynamics ``dyn`` need to forget their start state (see
    :func:`_filter_start`); -1 when they never do."""
    stage = EFFECTS[dyn[0]].dynamics
    assert stage is not None and stage.transfer is not None
    num, den = stage.transfer(tuple(dyn[1:]))
    a = discretised_tf(num, den, dt)[1]
    rho = float(np.max(np.abs(np.roots(a)))) if a.size > 1 else 0.0
    if not rho < 1.0:
        return -1
    warm = (np.log(WARM_DECAY) / np.log(rho) if rho > 0 else 0.0) + a.size + 1
    return int(np.ceil(warm)) if np.isfinite(warm) else -1


def _gram(X: np.ndarray, nq: int, cache: _Cache, key: Any, owner: Any) -> np.ndarray:
    """``X.T @ X`` with the block of the first ``nq`` columns (the PI stage: play bank through
    the output dynamics) memoised in ``cache`` on ``key``; ``owner`` is kept with the entry
    and must be the same object on a hit (its identity is part of the key).

    A miss forms the whole matrix in one symmetric product (one pass over the ``(N, p)``
    rows; the block alone and then its cross products read the PI-stage columns twice). On
    a hit only the cross products of the other columns (bilinear regressors, bias, drift,
    output: they change between structures and refreshes) are formed, as ``X2.T @ X`` (the
    thin factor on the left reads the wide block once, in row order)."""
    hit = _recent(cache.g, key)
    if hit is not None and hit[0] is owner:
        X2 = np.ascontiguousarray(X[:, nq:])
        G = np.empty((X.shape[1], X.shape[1]))
        G[:nq, :nq] = hit[1]
        G[nq:, :] = X2.T @ X
        G[:nq, nq:] = G[nq:, :nq].T
        return G
    G = X.T @ X
    if len(cache.g) >= 16:
        cache.g.pop(next(iter(cache.g)))
    cache.g[key] = (owner, G[:nq, :nq].copy())
    return G


def _unconstrained_rss(Xa: np.ndarray) -> float:
    """Residual sum of squares of the unconstrained least-squares fit of the last column of
    ``Xa`` on the others: Cholesky of the column-scaled normal equations, or ``lstsq`` when
    they are ill conditioned (condition number above :data:`core.fitting.gram.COND_LIMIT`)."""
    G = Xa.T @ Xa
    p = G.shape[0] - 1
    d = np.sqrt(np.diag(G)[:p])
    d[d == 0] = 1.0
    Gs = G[:p, :p] / d[:, None] / d[None, :]
    ev = np.linalg.eigvalsh(Gs)
    if ev[0] > 0 and ev[-1] <= COND_LIMIT * ev[0]:
        L = np.linalg.cholesky(Gs)
        w = np.linalg.solve(L.T, np.linalg.solve(L, G[:p, p] / d)) / d
    else:
        w = np.linalg.lstsq(Xa[:, :p], Xa[:, p], rcond=None)[0]
    e = Xa @ np.append(w, -1.0)
    return float(e @ e)


def _level_penalty(n_play: int, m: int, ncol: int, lam: float) -> np.ndarray:
    """Pseudo rows ``sqrt(lam) (W[i, j] - W[i, j - 1])`` of a Preisach base (column
    ``i m + j``), zero in the output column; ``(n_play (m - 1), ncol + 1)``."""
    P = np.zeros((n_play * (m - 1), ncol + 1))
    q = np.sqrt(lam)
    row = 0
    for i in range(n_play):
        for j in range(1, m):
            P[row, i * m + j] = q
            P[row, i * m + j - 1] = -q
            row += 1
    return P


def legendre_columns(t: np.ndarray, deg: int) -> np.ndarray:
    """Legendre polynomials of degrees 1 to ``deg`` of the time ``t`` (s) mapped onto
    ``[-1, 1]`` over the recording, shape ``(t.size, deg)`` (a drift's columns, and the own
    level of a left-out recording)."""
    s = 2.0 * (t - t[0]) / max(t[-1] - t[0], 1e-12) - 1.0
    return np.column_stack(
        [np.polynomial.legendre.legval(s, np.eye(deg + 1)[k]) for k in range(1, deg + 1)]
    )


@overload
def fit_structure(
    s: Structure, records: Sequence[Recording], train: Sequence[np.ndarray],
    cache: _Cache | None = None, x_init: Sequence[np.ndarray] | None = None,
    iterations: int | None = None, rss_only: Literal[False] = False, reduce: bool = True,
) -> Fit: ...


@overload
def fit_structure(
    s: Structure, records: Sequence[Recording], train: Sequence[np.ndarray],
    cache: _Cache | None = None, x_init: Sequence[np.ndarray] | None = None,
    iterations: int | None = None, *, rss_only: bool, reduce: bool = True,
) -> Fit | float: ...


def fit_structure(
    s: Structure,
    records: Sequence[Recording],
    train: Sequence[np.ndarray],
    cache: _Cache | None = None,
    x_init: Sequence[np.ndarray] | None = None,
    iterations: int | None = None,
    rss_only: bool = False,
    reduce: bool = True,
) -> Fit | float:
    """Fit the linear weights of structure ``s`` on the training rows and simulate it exactly.

    Parameters
    ----------
    s : Structure
    records : sequence of Recording
    train : sequence of ndarray of bool
        Training rows per recording.
    cache : optional play-bank cache shared between calls.
    rss_only : bool
        Return only the training residual sum of squares of the linear solve (fast path for
        the search over nonlinear parameters; no chain is built or simulated).
    reduce : bool
        With ``rss_only``, replace the play bank by its leading right-singular directions on
        the training rows (relative singular value > 1e-6, at most 24) and solve without the
        sign constraints: several times faster, used only to rank nonlinear parameters.
    x_init : sequence of ndarray, optional
        PI-stage outputs of a previous fit; the creep and asymmetry regressors are evaluated
        on them (they are bilinear in the play weights) and refreshed ``iterations`` times.

    Returns
    -------
    Fit, or float with ``rss_only``
    """
    cache = cache or _Cache()
    r = np.asarray(s.thresholds)
    nrec = len(records)
    layout = cache.layout(records, train, rss_only)
    rows, sel, ends, upto, ys, ylo, yhi, center, half, dts = layout
    starts = [_filter_start(s.dynamics, dts[k], int(idx[0]) if idx.size else 0)
              for k, idx in enumerate(rows)]
    vkey = (s.history, s.beta_s, r.size, float(r[-1]), s.shape, s.levels, s.bouc_wen)
    bs = _bank_set(cache, s, records, train, rows, upto, starts, vkey, rss_only, reduce)
    V = bs.V
    info = TermFit(nrec, center, half)
    needs_x = s.reads_output
    if iterations is None:
        iterations = 3 if needs_x else 1
    # (read only by the bilinear regressors: the PI-stage outputs are formed on first use)
    x_prev: Sequence[Float1D] | None = list(x_init) if x_init is not None and needs_x else None
    n_lev = len(s.levels) + 1
    nb = (r.size + 1) * n_lev
    nq = nb if V is None else V.shape[1]
    # the static terms with columns, in column order: (name, term, settings, first, end)
    terms, ncol = _term_columns(s, nq, nrec)
    # the terms before the output dynamics: read the PI-stage output, filtered as it is
    inner = [t for t in terms if t[1].through_dynamics]
    nM = inner[-1][4] if inner else nq
    # design matrix with the output as its last column, filled block by block; the PI-stage
    # columns (play bank, or its reduced basis, through the dynamics), the terms after the
    # dynamics (bias, drift) and the output are the same in every refresh of the bilinear
    # regressors, so they are filled once
    X = np.empty((ys.size, ncol + 1))
    blocks = []
    o = 0
    for k, (rec, idx, last) in enumerate(zip(records, rows, ends, strict=True)):
        blk = X[o : o + idx.size]
        blocks.append(blk)
        _pi_rows(bs, s, cache, (k, vkey, last), idx, last, starts[k], sel[k], dts[k],
                 blk[:, :nq])
        for _, t, v, a, b in terms:
            if not t.through_dynamics:
                blk[:, a:b] = t.columns(v, TermRows(rec, k, idx, None, info))
        blk[:, ncol] = ys[o : o + idx.size]
        o += idx.size
    # (the bounds only matter to the constrained solve: not formed for the reduced ranking)
    lower = None if V is not None else _constraints(
        s, X, nb, _min_slope([B[:, 0] for B in bs.raw] if bs.streamed is None
                             else [w for w, _ in bs.streamed], train, ylo, yhi), terms)
    w = None
    for it in range(iterations):
        if needs_x:
            if x_prev is None:
                # first pass without the bilinear regressors to get the PI-stage output
                f0 = fit_structure(s.without_terms(through_dynamics=True), records, train,
                                   cache)
                x_prev = f0.x_pi
            for k, (idx, last) in enumerate(zip(rows, ends, strict=True)):
                s0 = starts[k]
                x = x_prev[k][:last]
                # (a term's columns run from sample 0: only the output dynamics start late)
                cols = [t.columns(v, TermRows(records[k], k, idx, x, info))[s0:]
                        for _, t, v, _, _ in inner]
                _dyn_rows(cols[0] if len(cols) == 1 else np.column_stack(cols), s.dynamics,
                          dts[k], idx - s0, out=blocks[k][:, nq:nM])
        if lower is None:
            # reduced basis: unconstrained least squares (ranking of nonlinear parameters)
            return _unconstrained_rss(X)
        G = _gram(X, nq, cache, (id(layout), vkey, s.dynamics, s.free_weights), layout)
        w = _solve(s, X, G, lower, nb)
        if rss_only and it == iterations - 1:
            return float(np.sum((X[:, :ncol] @ w - X[:, ncol]) ** 2))
        if s.stop:  # Maxwell-slip stiffnesses k, w_i -> play frame p0 = k + sum w, p = -w
            w[1:nb] = -w[1:nb]
            w[0] -= float(np.sum(w[1:nb]))
        elif s.free_weights and not s.bouc_wen:
            w[:nb] = np.diff(w[:nb], prepend=0.0)  # slopes -> weights
        if needs_x and it < iterations - 1:
            # (the regressors read the PI-stage outputs up to the last solved row only)
            x_prev = [bs.banks[k][: ends[k]] @ w[:nb] if bs.streamed is None else
                      _streamed_product(*bs.streamed[k], np.r_[0.0, r], s.levels, w[:nb],
                                        ends[k])
                      for k in range(nrec)]
    assert w is not None
    coef = {name: t.coefficients(v, np.asarray(w[a:b]), info) for name, t, v, a, b in terms}
    return _simulated(s, records, train, bs.banks, float(w[0]), np.asarray(w[1:nb]), coef,
                      cache)


class _BankSet(NamedTuple):
    """The play banks (or Bouc-Wen banks) of one structure fit: ``raw`` per recording,
    ``banks`` (split into level segments on a Preisach base), the reduced basis ``V``
    (``None`` for a full fit); for a ranking solve of banks not in the cache
    (:func:`_sampled_banks`, then ``raw`` and ``banks`` are empty) the bank ``inputs`` and
    the bank rows the products start from, ``row0``; ``r_bank``: the thresholds of the
    bank's columns when the reduced products are formed along the input
    (:func:`_bank_rows_times`), else ``None``."""

    raw: list
    banks: list
    V: np.ndarray | None
    inputs: list | None
    row0: list | None
    r_bank: np.ndarray | None
    #: a full fit of a bank too large to keep (:func:`_streams`): per recording the bank
    #: input and its row-0 state ``(w, z0)``, the plays streamed in row blocks; else None
    streamed: list[tuple[np.ndarray, np.ndarray]] | None = None


def _bank_set(cache: _Cache, s: Structure, records: Sequence[Recording],
              train: Sequence[np.ndarray], rows: list[np.ndarray], upto: list[int],
              starts: list[int], vkey: Any, rss_only: bool, reduce: bool) -> _BankSet:
    """The banks of :func:`fit_structure` (:class:`_BankSet`)."""
    r = np.asarray(s.thresholds)
    # a ranking solve of rate-independent plays whose bank is not kept (a history or loop
    # shape met once): the plays run along the input storing only the rows the reduced
    # basis and the products start from (_sampled_banks), not their (N, n) outputs
    sampled = (_sampled_banks(cache, s, records, train, rows, upto, starts, vkey)
               if rss_only and reduce and not s.levels and s.beta_s is None
               and not s.bouc_wen else None)
    inputs = row0 = streamed = None
    banks: list[np.ndarray]
    if sampled is not None:
        raw = banks = []
        V, inputs, row0 = sampled
    elif not rss_only and _streams(cache, s, records):
        raw = banks = []
        V = None
        streamed = [_bank_start(s, rec, k) for k, rec in enumerate(records)]
    else:
        raw = [
            cache.bank(k, rec, r, s.history[k], s.beta_s, upto=upto[k] if rss_only else None,
                       shape=s.shape, bouc_wen=s.bouc_wen)
            for k, rec in enumerate(records)
        ]
        banks = raw if not s.levels else [cache.levelled(k, B, s) for k, B in enumerate(raw)]
        V = None
    if rss_only and reduce and not s.levels and V is None:
        # not on a Preisach base: its (n + 1) m level-segment columns are far more than the
        # basis keeps, and the truncated fit ranked nonlinear parameters wrongly (on the
        # Duhem plant a true 346 Hz mode ranked worse than none)
        V = cache.basis(banks, train, vkey)
    # thresholds of the play-bank columns (rate-independent plays: the reduced products
    # are then formed along the input, _bank_rows_times)
    r_bank = (np.r_[0.0, r] if V is not None and s.beta_s is None and not s.bouc_wen
              and not s.levels else None)
    return _BankSet(raw, banks, V, inputs, row0, r_bank, streamed)


def _pi_rows(bs: _BankSet, s: Structure, cache: _Cache, key: Any, idx: np.ndarray, last: int,
             start: int, sel: slice | np.ndarray, dt: float, out: np.ndarray) -> None:
    """The PI-stage columns of one recording on its solved rows ``idx`` (up to ``last``),
    through the output dynamics, written to ``out``: the bank (or its reduced basis ``V``)
    from the dynamics' ``start`` sample; ``key``: the recording's projection key."""
    V, k = bs.V, key[0]
    if bs.streamed is not None:
        w, z0 = bs.streamed[k]
        _streamed_rows(w, np.r_[0.0, s.thresholds], z0, s.levels, s.dynamics, dt, idx, start,
                       out)
    elif bs.inputs is not None:
        assert bs.row0 is not None and V is not None
        s0 = int(idx[0]) if not s.dynamics else start
        if not s.dynamics:
            out[...] = _input_rows_times(bs.inputs[k][s0:last], bs.row0[k], V, filled(bs.r_bank),
                                         idx - s0)
        elif idx.size:
            _dyn_rows(_input_rows_times(bs.inputs[k][s0:last], bs.row0[k], V, filled(bs.r_bank),
                                        np.arange(last - s0)),
                      s.dynamics, dt, idx - s0, out=out)
    elif V is not None and not s.dynamics:
        # only the solved rows are needed (a strided view when they are evenly spaced,
        # as in a single training window: the same product without gathering them)
        P = None if bs.r_bank is None else _bank_rows_times(bs.banks[k], V, bs.r_bank, idx)
        out[...] = bs.banks[k][sel] @ V if P is None else P
    else:
        # (the dynamics run from where their start transient has died out by the first
        # solved row, not from sample 0: the same rows to round-off)
        P = bs.banks[k][start:last] if V is None else cache.projected(
            bs.banks[k][:last], V, key,
            w=bs.raw[k][:last, 0] if s.beta_s is None else None, start=start, r=bs.r_bank)
        _dyn_rows(P, s.dynamics, dt, idx - start, out=out)


def _min_slope(inputs: list, train: Sequence[np.ndarray], ylo: float, yhi: float) -> float:
    """The smallest loop-segment slope of an invertible PI stage: 1e-3 of the output range
    over the range of the play bank's input ``inputs`` (per recording; the loop-shape map's
    output when there is one; a bank may stop at its last training row) on the training
    rows, as :func:`core.fitting.default_min_slope`."""
    w_tr = [w[m[: w.shape[0]]] for w, m in zip(inputs, train, strict=True) if m.any()]
    ulo = min(float(w.min()) for w in w_tr)
    uhi = max(float(w.max()) for w in w_tr)
    return 1e-3 * (yhi - ylo) / max(uhi - ulo, 1e-300)


def _constraints(s: Structure, X: np.ndarray, nb: int, eps: float, terms: list) -> np.ndarray:
    """Lower bounds of the weights (the columns of ``X`` but its last), ``nb`` base columns
    first, then the static ``terms`` (:func:`_term_columns`). An invertible PI stage (as the
    fitting's constraint_transform): free weights solve for the loop-segment slopes
    ``S_j = p0 + p_1 + ... + p_j >= eps`` (the columns of ``X`` become ``X_j - X_{j+1}``, in
    place), classical ones for ``p0 >= eps, p_j >= 0``; each term's weights within its own
    bound."""
    lower = np.full(X.shape[1] - 1, -np.inf)
    lower[:nb] = eps
    n_lev = len(s.levels) + 1
    if s.levels:
        # Preisach base: every segment of the reversible part rises (>= eps), the level
        # segments of the plays are a nonnegative relay density
        lower[n_lev:nb] = 0.0
    elif s.bouc_wen:
        # Bouc-Wen base: columns m_j u - z_j, weights >= 0 (an invertible hardening loop,
        # core.diagnosis.bases) or of either sign with free weights
        lower[1:nb] = -np.inf if s.free_weights else 0.0
    elif s.stop:
        # stop base: columns [v, v - Gamma_i(v)] (the elements' deflections), k >= eps and
        # w_i >= 0 (a clockwise, invertible Maxwell-slip bank)
        X[:, 1:nb] = X[:, :1] - X[:, 1:nb]
        lower[1:nb] = 0.0
    elif s.free_weights:
        X[:, : nb - 1] -= X[:, 1:nb]
    else:
        lower[1:nb] = 0.0
    for _, t, _, a, b in terms:
        lower[a:b] = t.lower
    return lower


def _solve(s: Structure, X: np.ndarray, G: np.ndarray, lower: np.ndarray, nb: int
           ) -> np.ndarray:
    """The weights of the design ``X`` (output in its last column; ``G`` its Gram matrix,
    added to in place) within ``lower``.

    The fitting's constrained solver, as core.fitting does it: from the augmented Gram
    matrix, or from the triangular factor of [X, y] when that is ill conditioned. Pseudo
    rows: a column without any solved row (the offset or drift of a recording left out,
    e.g. leave-one-recording-out) is pinned at 0, as if never there; then the unbounded
    weights (bias, drift, output map) also get a ridge 1e-9 of the largest column energy,
    bounding a direction the remaining rows leave (nearly) undetermined (before: offsets of
    1e12 with one recording left out). Fits with rows in every column are solved as they
    were (the ridge alone moved a weak drift on top of creep from a 7 % to a 13 % held-out
    gain: such designs are nearly collinear)."""
    ncol = lower.size
    dg = np.diag(G)[:ncol]
    empty = dg == 0
    ridge = 1e-9 * float(dg.max(initial=0.0)) if empty.any() else 0.0
    lam = np.where(empty, 1.0, np.where(np.isfinite(lower), 0.0, ridge))
    pin = (np.sqrt(lam)[:, None] * np.eye(ncol + 1)[:ncol])[lam > 0]
    if s.levels and s.level_smooth > 0:
        # a Preisach base: the density of neighbouring level segments of each play is
        # pulled together (towards a PI), so cells excited by few rows do not overfit
        n_lev = len(s.levels) + 1
        pin = np.vstack((pin, _level_penalty(len(s.thresholds) + 1, n_lev, ncol,
                                             s.level_smooth * float(dg[:nb].mean()))))
    if pin.size:
        G += pin.T @ pin
    sol = solve_constrained(lower, gram=G)
    if sol.cond > COND_LIMIT:
        sol = solve_constrained(lower, factor=r_factor(np.vstack((X, pin)) if pin.size else X))
    return sol.theta


def _simulated(s: Structure, records: Sequence[Recording], train: Sequence[np.ndarray],
               banks: list, p0: float, pw: np.ndarray, coef: dict[str, Any],
               cache: _Cache) -> Fit:
    """The :class:`Fit` of ``s`` with the solved weights: each recording's chain simulated
    exactly (its training RSS from those predictions). The fit keeps no bank: its PI-stage
    outputs are formed from ``cache`` when first read (:class:`PIStageOutputs`)."""
    models, preds = [], []
    rss = 0.0
    ntr = 0
    for k, (rec, m) in enumerate(zip(records, train, strict=True)):
        model = build_model(s, k, p0, pw, coef, rec)
        if s.bouc_wen and not s.shape and isinstance(model, Chain):
            # the Bouc-Wen stage's output is its bank times the weights (the bank integrates
            # the elements as the model does, to round-off): only the later stages are run
            x = banks[k] @ np.concatenate(([p0], pw))
            pred = Chain(model.stages[1:])(x, dt=rec.dt)
        else:
            pred = model(rec.u, dt=rec.dt)
        models.append(model)
        preds.append(pred)
        rss += float(np.sum((rec.y[m] - pred[m]) ** 2))
        ntr += int(m.sum())
    return Fit(structure=s, p0=p0, weights=pw, terms=coef, models=models, pred=preds,
               x_pi=PIStageOutputs(functools.partial(_stage_output, cache, s, tuple(records)),
                                   len(records), np.concatenate(([p0], pw))),
               train_rss=rss,
               n_train=ntr)

def _stage_output(cache: _Cache, s: Structure, records: Sequence[Recording], k: int,
                  w: np.ndarray) -> Float1D:
    """The PI-stage output ``bank @ w`` of recording ``k`` of structure ``s`` ``(N,)``.

    A rate-independent play bank that is not in ``cache`` is streamed: the plays run over
    blocks of :data:`STREAM_ROWS` rows with their state carried from block to block (the
    play update is exact, so the rows are those of the whole bank), and each block is
    multiplied and dropped, so the memory is one block, not ``(N, n + 1)``.
    """
    rec = records[k]
    r = np.asarray(s.thresholds)
    hist = s.history[k]
    if s.beta_s is None and not s.bouc_wen and not cache.has_bank(k, r, hist, s.shape):
        u, z0 = _bank_start(s, rec, k)
        return _streamed_product(u, z0, np.r_[0.0, r], s.levels, w, u.size)
    B = cache.bank(k, rec, r, hist, s.beta_s, shape=s.shape, bouc_wen=s.bouc_wen)
    return (cache.levelled(k, B, s) if s.levels else B) @ w


def _streams(cache: _Cache, s: Structure, records: Sequence[Recording]) -> bool:
    """Whether a full fit of ``s`` streams its play banks in row blocks instead of forming
    them (:func:`_streamed_rows`): rate-independent plays on a PI or Preisach base, banks
    not cached and together larger than the cache's budget
    (:func:`~.cache_budget.cache_budget` of the diagnosis's samples; a short recording is
    fitted from its whole bank, as before), and output dynamics that forget their start (a block's
    rows are those of the filter run from the first sample to round-off, as
    :func:`_filter_start`)."""
    if s.beta_s is not None or s.bouc_wen:
        return False
    r = np.asarray(s.thresholds)
    if any(cache.has_bank(k, r, s.history[k], s.shape) for k in range(len(records))):
        return False
    width = (r.size + 1) * (len(s.levels) + 1)
    if cache.budget.fits(8.0 * width * sum(rec.n_samples for rec in records)):
        return False
    return all(_warm_rows(s.dynamics, rec.dt) >= 0 for rec in records)


def _warm_rows(dyn: tuple, dt: float) -> int:
    """Samples before a row the output dynamics ``dyn`` must run from (:func:`_filter_start`),
    0 without dynamics; -1 when they never forget their start."""
    if not dyn:
        return 0
    far = 2**62
    first = _filter_start(dyn, dt, far)
    return -1 if first == 0 else far - first


def _bank_start(s: Structure, rec: Recording, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The input of the play bank of recording ``k`` (through the loop shape) and the
    state of the bank ``[w, plays(w)]`` before its first sample (the virtual history's)."""
    r = np.asarray(s.thresholds)
    hist = s.history[k]
    z = play_bank(apply_shape(s.shape, hist), r)[1] if hist else np.zeros(r.size)
    return np.ascontiguousarray(apply_shape(s.shape, rec.u), dtype=np.float64), np.r_[0.0, z]


def _streamed_product(w: np.ndarray, z0: np.ndarray, r_full: np.ndarray, levels: tuple,
                      weights: np.ndarray, upto: int) -> Float1D:
    """``B[:upto] @ weights`` for the play bank ``B`` of thresholds ``r_full`` on input ``w``
    from state ``z0`` (split into the level segments of ``levels``, :func:`_segments`), the
    plays run over blocks of :data:`STREAM_ROWS` rows with their state carried (the play
    update is exact: the rows of the whole bank), each block multiplied and dropped."""
    out = np.empty(upto)
    z = z0
    for a in range(0, upto, STREAM_ROWS):
        B, z = play_bank(w[a : min(a + STREAM_ROWS, upto)], r_full, z)
        out[a : a + B.shape[0]] = _segments(B, levels) @ weights
    return out


def _streamed_rows(w: np.ndarray, r_full: np.ndarray, z0: np.ndarray, levels: tuple,
                   dyn: tuple, dt: float, idx: np.ndarray, start: int, out: np.ndarray) -> None:
    """Rows ``idx`` of the play bank of thresholds ``r_full`` on input ``w`` (state ``z0``
    before it; split into the level segments of ``levels``, :func:`_segments`) through the
    output dynamics ``dyn`` started at row ``start``, written to ``out`` ``(idx.size,
    width)``, with at most :data:`STREAM_ROWS` plus the dynamics' warm-up of bank rows alive.

    Without dynamics the plays run storing only the rows ``idx`` (:func:`_play_rows`, the
    bank's numbers). With them the solved rows go in groups of a block; the first group's
    filter starts at ``start`` (the rows of the whole bank's), each later group's where its
    start transient has died out by its first row (:func:`_filter_start`: the rows of the
    filter run from ``start`` to round-off), on bank rows kept from the block before."""
    if not idx.size:
        return
    if not dyn:
        B = _play_rows(w, r_full, z0.copy(), np.asarray(idx, dtype=np.int64),
                       np.empty((idx.size, r_full.size)))
        out[...] = _segments(B, levels)
        return
    # the plays' state at row `start` (rows before it are not needed)
    z = z0
    for a in range(0, start, STREAM_ROWS):
        z = play_bank(w[a : min(a + STREAM_ROWS, start)], r_full, z)[1]
    have, have0 = np.empty((0, r_full.size)), start  # bank rows [have0, have0 + len(have))
    done = 0
    while done < idx.size:
        end = int(np.searchsorted(idx, int(idx[done]) + STREAM_ROWS))
        group = idx[done:end]
        s0 = start if done == 0 else max(start, _filter_start(dyn, dt, int(group[0])))
        pos = have0 + have.shape[0]
        # the rows between the kept ones and this group's filter start are not needed: the
        # plays' state is carried over them in blocks (a held-out block of a long record is
        # N / 16 rows; holding its bank rows made the peak grow with the record)
        for a in range(pos, s0, STREAM_ROWS):
            z = play_bank(w[a : min(a + STREAM_ROWS, s0)], r_full, z)[1]
        pos = max(pos, s0)
        new, z = play_bank(w[pos : int(group[-1]) + 1], r_full, z)
        have = np.concatenate((have[s0 - have0:], new)) if s0 < pos else new
        have0 = s0
        _dyn_rows(_segments(have, levels), dyn, dt, group - s0, out=out[done:end])
        done = end


def _term_columns(s: Structure, first: int, n_records: int
                  ) -> tuple[list[tuple[str, StaticTerm, Any, int, int]], int]:
    """The static terms of ``s`` with columns, in column order from column ``first``:
    ``[(name, term, settings, start, end), ...]``, and the column after the last."""
    out = []
    o = first
    for name, t, _ in static_terms():
        v = s.term(name)
        n = t.width(v, n_records)
        if n:
            out.append((name, t, v, o, o + n))
            o += n
    return out, o


def build_model(s: Structure, k: int, p0: float, pw: Float1D, terms: dict[str, Any],
                rec: Recording) -> Model:
    """The exact chain of structure ``s`` for recording ``k``.

    Parameters
    ----------
    s : Structure
    k : int
        Index of the recording.
    p0, pw : float, ndarray
        Weights of the base hysteresis (the reversible part and the plays or elements).
    terms : dict
        Coefficients of the static terms by effect name (:attr:`Fit.terms`); a term with
        columns but no coefficients here adds no stage.
    rec : Recording
        The recording (its time span sets a drift's).
    """
    stages: list[Model] = [_hysteresis(s, k, p0, pw)]
    for through in (True, False):
        # the terms before the output dynamics, the dynamics, the terms after them
        stages += [t.stage(s.term(name), terms[name], k, rec)
                   for name, t, _ in static_terms()
                   if t.through_dynamics == through and name in terms]
        if through:
            stages += [dynamics_of(name).model(v)
                       for name, v in dynamics_stages(s.dynamics)]
    return Chain.of(*stages)


def _hysteresis(s: Structure, k: int, p0: float, pw: Float1D) -> Model:
    """The base hysteresis of structure ``s`` for recording ``k`` (its loop shape and
    initial memory included) with the weights ``p0, pw``."""
    r = np.asarray(s.thresholds)
    hyst: Model
    gap = gap_stage_of(s.shape)
    if gap is not None:
        # stop base: the sliders start where the (mapped) history leaves the plays
        hist = s.history[k]
        z0 = play_bank(apply_shape((gap,), np.asarray(hist, dtype=np.float64)), r)[1] \
            if hist else None
        return hysteresis_model(loop_shape(s.shape), stop_model(gap, r, p0, pw, z0))
    if s.bouc_wen:
        # a virtual history sets the elements' start state (on the mapped input)
        st = initial_state(s.bouc_wen, apply_shape(s.shape, np.asarray(s.history[k]))
                           if s.history[k] else None)
        hyst = bouc_wen_model(max(p0, 0.0), pw if s.free_weights else np.maximum(pw, 0.0),
                              s.bouc_wen, st)
        if s.shape:
            hyst = hysteresis_model(s.shape, hyst)
    elif s.levels:
        W = np.maximum(np.r_[p0, pw], 0.0).reshape(r.size + 1, len(s.levels) + 1)
        hyst = PreisachModel(np.r_[0.0, r], W, knots=np.asarray(s.levels)) if s.beta_s is None \
            else RateDependentPreisach(np.r_[0.0, r], W, s.beta_s, knots=np.asarray(s.levels))
    elif s.beta_s is None:
        hyst = PIModel(max(p0, 0.0), r, pw if s.free_weights else np.maximum(pw, 0.0))
    else:
        hyst = RateDependentPI(max(p0, 0.0), r, pw if s.free_weights else np.maximum(pw, 0.0),
                               s.beta_s)
    if s.bouc_wen:
        pass  # shape and history are in the Bouc-Wen stage already
    elif s.shape:
        # the plays run on the mapped input: their initial memory is the mapped history
        if s.history[k]:
            hyst = InitialMemory(hyst, apply_shape(s.shape, np.asarray(s.history[k]))
                                 ).with_state()
        hyst = hysteresis_model(s.shape, hyst)
    elif s.history[k]:
        hyst = InitialMemory(hyst, np.asarray(s.history[k], dtype=np.float64))
    return hyst
