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
from collections.abc import Callable, Iterator, Sequence
from dataclasses import MISSING, dataclass, field, fields, replace
from typing import Any, Literal, NamedTuple, overload

import numpy as np

from .._typing import Float1D
from ..base import Chain, Model
from ..operators import play_bank
from ..pi import PIModel
from ..preisach import PreisachModel, RateDependentPreisach
from ..recordings import Recording
from ..stages import InitialMemory, RateDependentPI, SignedGain, discretised_tf
from ..validation import filled
from .bankcache import BankCache, basis_of, basis_rows, recent, split_levels
from .bases import (
    MP,
    bouc_wen_model,
    element_family,
    initial_state,
    menegotto_pinto_model,
    stop_model,
)
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
from .rowkernels import (
    bank_rows_times,
    delay_rows,
    iir_rows,
    input_rows_times,
    play_rows,
    row_selector,
    turns_rarely,
)
from .shapes import (
    apply_shape,
    gap_stage_of,
    hysteresis_model,
    loop_shape,
    shape_effects,
    signed_ratio,
)
from .solver import constraints, gram, min_slope, solve, still_elements, unconstrained_rss

__all__ = ["Fit", "HeldWeights", "PIStageOutputs", "Structure", "baseline_thresholds",
           "build_model", "term_columns_at",
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
        ``(beta + gamma)^(-1/n)``; ``()`` = a PI or Preisach base. Or the elements
        ``(MP, sign, r, R0, cR1, cR2)`` of a Menegotto-Pinto base (non-Masing loops:
        :func:`core.diagnosis.bases.menegotto_pinto_elements`), the same way: columns of
        fixed-shape elements, ``thresholds`` their yield levels, weights ``>= 0``.
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
    bouc_wen: tuple[tuple[Any, ...], ...] = ()

    @property
    def base_kind(self) -> str:
        """The base hysteresis: ``"bouc-wen"``, ``"menegotto-pinto"``, ``"preisach"``
        (level-dependent memory), ``"stop-pi"`` (stop operators behind a backlash gap) or
        ``"pi"``: a key of :data:`~core.diagnosis.bases.BASE_KINDS`, which declares each
        kind with its words."""
        return (element_family(self.bouc_wen) if self.bouc_wen else "preisach" if self.levels
                else "stop-pi" if self.stop else "pi")

    @property
    def stop(self) -> bool:
        """A stop-operator base (its input map first in :attr:`shape`)."""
        return gap_stage_of(self.shape) is not None

    @property
    def signed(self) -> bool:
        """A stop base whose slip force depends on the sliding direction (its input map
        carries the ratio, :func:`core.diagnosis.bases.stop_stage`): its bank's rows are
        times their gain, so the banks are never formed along the input from the
        thresholds alone (streamed, sampled, projected along the input)."""
        return signed_ratio(self.shape) != 1.0

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
    def play_weights(self) -> int:
        """Weights of the play bank: one a play, or one a play and level segment on a
        Preisach base (what the resolution refinement's ceiling and the recordings' spread
        count; the reversible play and the static terms not included)."""
        return len(self.thresholds) * (len(self.levels) + 1)

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
    raw_fallback : tuple of str
        Effects whose term was to be fitted on changes between rows of the same input
        history (:mod:`core.diagnosis.changes`) but was solved on all the training rows,
        because those weights, held, fitted the training rows worse than the structure
        without the term (:meth:`core.diagnosis.context.FitContext.fit`); empty otherwise.
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
    raw_fallback: tuple[str, ...] = ()

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


#: Rows of a block of the play bank streamed by :func:`_stage_output` (0.2 MB per play; 50,000
#: held 70 MB of a resolution refit's bank at the 100,000-sample diagnosis's peak).
STREAM_ROWS = 25_000


def _sampled_banks(cache: BankCache, s: Structure, records: Sequence[Recording],
                   train: Sequence[np.ndarray], rows: list[np.ndarray], upto: list[int],
                   starts: list[int], vkey: Any
                   ) -> tuple[np.ndarray, list[np.ndarray], list[np.ndarray]] | None:
    """What a ranking solve of rate-independent plays needs of banks not in ``cache``: the
    reduced basis (memoised on ``vkey``), and per recording the bank input (the input through
    the loop shape, up to ``upto``) and the bank row the products start from (``starts``, or
    the first solved row of ``rows`` without dynamics). The plays run along the input storing
    only the basis rows and those (:func:`play_rows`, the numbers of the full bank). ``None``
    when a bank is in the cache or an input reverses often (the product is then cheaper)."""
    r = np.asarray(s.thresholds)
    r_full = np.r_[0.0, r]
    if any(cache.has_bank(k, r, s.history[k], s.shape) for k in range(len(records))):
        return None
    inputs, row0, samples = [], [], []
    for k, (rec, m, idx) in enumerate(zip(records, train, rows, strict=True)):
        w = apply_shape(s.shape, rec.u[: upto[k]])
        first = (starts[k] if s.dynamics else int(idx[0])) if idx.size else 0
        if idx.size and not turns_rarely(w[first : int(idx[-1]) + 1], r_full.size):
            return None
        hist = s.history[k]
        z0 = play_bank(apply_shape(s.shape, hist), r)[1] if hist else np.zeros(r.size)
        ib = basis_rows(m)
        # (the basis rows are increasing: the start row goes in its place)
        at = int(np.searchsorted(ib, first))
        need = (ib if at < ib.size and ib[at] == first else np.insert(ib, at, first)).astype(
            np.int64)
        B = play_rows(np.ascontiguousarray(w, dtype=np.float64), r_full, np.r_[0.0, z0],
                       need, np.empty((need.size, r_full.size)))
        inputs.append(w)
        row0.append(B[np.searchsorted(need, first)] if need.size else np.zeros(r_full.size))
        samples.append(B[np.searchsorted(need, ib)])
    V = recent(cache.v, vkey)
    if V is None:
        V = basis_of(np.concatenate(samples))
        if len(cache.v) >= 64:
            cache.v.pop(next(iter(cache.v)))
        cache.v[vkey] = V
    return V, inputs, row0


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
        out[...] = x[row_selector(rows)]  # (a strided view for evenly spaced rows: no gather)
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
        return delay_rows(xc, np.asarray(rows, dtype=np.int64), m, D - m, out)
    num, den = stage.transfer(tuple(dyn[1:]))
    b, a, zi = discretised_tf(num, den, dt)
    return iir_rows(b, a, zi, xc, np.asarray(rows, dtype=np.int64), out)


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
    cache: BankCache | None = None, x_init: Sequence[np.ndarray] | None = None,
    iterations: int | None = None, rss_only: Literal[False] = False, reduce: bool = True,
    held: Sequence[HeldWeights] = (),
) -> Fit: ...


@overload
def fit_structure(
    s: Structure, records: Sequence[Recording], train: Sequence[np.ndarray],
    cache: BankCache | None = None, x_init: Sequence[np.ndarray] | None = None,
    iterations: int | None = None, *, rss_only: bool, reduce: bool = True,
    held: Sequence[HeldWeights] = (),
) -> Fit | float: ...


def fit_structure(
    s: Structure,
    records: Sequence[Recording],
    train: Sequence[np.ndarray],
    cache: BankCache | None = None,
    x_init: Sequence[np.ndarray] | None = None,
    iterations: int | None = None,
    rss_only: bool = False,
    reduce: bool = True,
    held: Sequence[HeldWeights] = (),
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
    held : sequence of HeldWeights
        Weights of static terms fixed beforehand (a slow term fitted on the changes between
        rows of the same input history, :meth:`~core.diagnosis.context.FitContext.fit`):
        their columns times those weights are subtracted from the output and the other
        weights solved on the training rows as usual; the term's other weights are free.

    Returns
    -------
    Fit, or float with ``rss_only``
    """
    cache = cache or BankCache()
    if rss_only:
        # a search reads a long record's prefix only (:mod:`.screening`)
        train = cache.ranking_masks(records, train)
    else:
        # the searches' products beyond the budget are not held while a full fit forms its
        # banks (they would add to the diagnosis's peak)
        cache.rp.clear()
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
    # (before constraints() turns a stop base's play columns into its deflections)
    fixed = None if V is not None else still_elements(
        s, X, nb, _plain_plays(cache, s, records, rows) if s.signed else None)
    lower = None if V is not None else constraints(
        s, X, nb, min_slope([B[:, 0] for B in bs.raw] if bs.streamed is None
                             else [w for w, _ in bs.streamed], train, ylo, yhi), terms)
    w = None
    hold = _held_columns(held, terms, ncol)
    # without output dynamics, regressors that read each row's PI-stage output alone (no
    # filter) need it on the solved rows only: refreshed from the solve's own columns
    # instead of the bank on every sample (the same numbers to round-off)
    on_rows = needs_x and not s.dynamics and not any(t.sample_spacing for _, t, *_ in inner)
    for it in range(iterations):
        if needs_x:
            if x_prev is None:
                # first pass without the bilinear regressors to get the PI-stage output
                f0 = fit_structure(s.without_terms(through_dynamics=True), records, train,
                                   cache)
                x_prev = f0.x_pi
            for k, (idx, last) in enumerate(zip(rows, ends, strict=True)):
                # (on the solved rows only, or every sample up to the last solved row)
                x = (x_prev[k] if it else np.asarray(x_prev[k][:last])[idx]) if on_rows else (
                    x_prev[k][:last])
                _bilinear_columns(inner, TermRows(records[k], k, idx, x, info), s.dynamics,
                                  starts[k], on_rows, blocks[k][:, nq:nM])
        if lower is None:
            # reduced basis: unconstrained least squares (ranking of nonlinear parameters)
            return unconstrained_rss(X)
        w = _solve_holding(s, X, ys, hold, lower, nb, fixed, lambda: gram(
            X, nq, cache, (id(layout), vkey, s.dynamics, s.free_weights), layout))
        if rss_only and it == iterations - 1:
            return float(np.sum((X[:, :ncol] @ w - X[:, ncol]) ** 2))
        w_solved = w.copy()
        if s.stop:  # Maxwell-slip stiffnesses k, w_i -> play frame p0 = k + sum w, p = -w
            w[1:nb] = -w[1:nb]
            w[0] -= float(np.sum(w[1:nb]))
        elif s.free_weights and not s.bouc_wen:
            w[:nb] = np.diff(w[:nb], prepend=0.0)  # slopes -> weights
        if needs_x and it < iterations - 1:
            x_prev = _refreshed_x(bs, s, blocks, ends, w_solved[:nb] if on_rows else None,
                                  w[:nb])
    assert w is not None
    coef = {name: t.coefficients(v, np.asarray(w[a:b]), info) for name, t, v, a, b in terms}
    return _simulated(s, records, train, bs.banks, float(w[0]), np.asarray(w[1:nb]), coef,
                      cache)


@dataclass(frozen=True)
class HeldWeights:
    """Weights of one static term fixed before a structure fit (:func:`fit_structure`).

    The structure fit subtracts their columns' share from the output and leaves them out
    of its solve (:func:`_solve_holding`).

    Attributes
    ----------
    name : str
        The effect whose term it is.
    weights : ndarray, shape (width,)
        The term's weights (its slice of the solved weights); read where ``held``.
    held : ndarray of bool, shape (width,)
        Which of them are fixed (the others are solved with the rest of the structure).
    """

    name: str
    weights: np.ndarray
    held: np.ndarray


def _held_columns(held: Sequence[HeldWeights], terms: list, ncol: int
                  ) -> tuple[np.ndarray, np.ndarray] | None:
    """The held weights over all ``ncol`` columns of a structure fit: ``(mask, weights)``
    (zero where not held), or ``None`` when nothing is held."""
    if not held:
        return None
    mask = np.zeros(ncol, dtype=bool)
    vals = np.zeros(ncol)
    by_name = {h.name: h for h in held}
    for name, _, _, a, b in terms:
        h = by_name.get(name)
        if h is not None:
            mask[a:b] = h.held
            vals[a:b] = np.where(h.held, h.weights, 0.0)
    return (mask, vals) if mask.any() else None


def _solve_holding(s: Structure, X: np.ndarray, ys: np.ndarray,
                   hold: tuple[np.ndarray, np.ndarray] | None, lower: np.ndarray, nb: int,
                   fixed: np.ndarray | None, gram_of: Callable[[], np.ndarray]) -> np.ndarray:
    """:func:`~.solver.solve` of the design ``X`` (the output ``ys`` in its last column),
    with the weights ``hold`` (``(mask, weights)``, :func:`_held_columns`) fixed: their
    columns' share is taken from the output and they are left out of the solve. ``gram_of``
    forms the Gram matrix of ``X`` as it then is. ``X``'s last column is ``ys`` again on
    return."""
    if hold is None:
        return solve(s, X, gram_of(), lower, nb, fixed)
    mask, vals = hold
    X[:, -1] = ys - X[:, :-1] @ vals
    w = solve(s, X, gram_of(), lower, nb, mask if fixed is None else fixed | mask)
    w[mask] = vals[mask]
    X[:, -1] = ys
    return w


def term_columns_at(s: Structure, name: str, records: Sequence[Recording], k: int,
                    rows: np.ndarray, x: np.ndarray | None, center: float = 0.0,
                    half: float = 1.0) -> np.ndarray:
    """The columns of the static term ``name`` of structure ``s`` for recording ``k`` on the
    sample indices ``rows`` (increasing), as the structure fit forms them: a term acting
    before the output dynamics reads the PI-stage output ``x`` (every sample up to the last
    row; output units) and its columns pass through the dynamics of ``s`` (from sample 0);
    the others are read on ``rows`` alone. ``center`` and ``half``: the training output's
    centre and half range (an output map's coordinate). Shape ``(rows.size, width)``."""
    terms, _ = _term_columns(s, 0, len(records))
    for n, t, v, _, _ in terms:
        if n != name:
            continue
        info = TermFit(len(records), center, half)
        rec = records[k]
        if not t.through_dynamics:
            return t.columns(v, TermRows(rec, k, rows, None, info))
        assert x is not None
        last = int(rows[-1]) + 1 if rows.size else 0
        cols = t.columns(v, TermRows(rec, k, rows, np.asarray(x[:last]), info))
        return _dyn_rows(cols, s.dynamics, rec.dt, rows)
    raise ValueError(f"{name!r} has no columns in {s}")


def _plain_plays(cache: BankCache, s: Structure, records: Sequence[Recording],
                 rows: list[np.ndarray]) -> np.ndarray:
    """The play bank of a signed stop base on the solved ``rows`` of every recording
    without the gains of its slip force by direction, ``(rows, n + 1)`` (what
    :func:`~.solver.still_elements` tests: an element that never slides has a constant
    column there)."""
    gap = gap_stage_of(s.shape)
    assert gap is not None
    plain = (gap[:5], *s.shape[1:])
    r = np.asarray(s.thresholds)
    return np.concatenate([cache.bank_rows(k, rec, r, s.history[k], None, plain, idx)
                           for k, (rec, idx) in enumerate(zip(records, rows, strict=True))])


def _refreshed_x(bs: _BankSet, s: Structure, blocks: list[np.ndarray], ends: list[int],
                 w_rows: np.ndarray | None, w: np.ndarray) -> list[np.ndarray]:
    """The PI-stage outputs the bilinear regressors are refreshed from, per recording: on the
    solved rows, the PI-stage part of the solve's prediction (``blocks``' first columns times
    ``w_rows``, the weights as solved) when ``w_rows`` is given; else the bank times the
    play-frame weights ``w`` up to the last solved row (``ends``)."""
    if w_rows is not None:
        return [blk[:, : w_rows.size] @ w_rows for blk in blocks]
    r = np.r_[0.0, s.thresholds]
    return [bs.banks[k][:end] @ w if bs.streamed is None else
            _streamed_product(*bs.streamed[k], r, s.levels, w, end)
            for k, end in enumerate(ends)]


def _bilinear_columns(inner: list, rows: TermRows, dynamics: tuple, start: int, on_rows: bool,
                      out: np.ndarray) -> None:
    """The columns of the terms ``inner`` (those read from the PI-stage output ``rows.x``) on
    the solved rows ``rows.rows``, written to ``out``. With ``on_rows`` (no output dynamics,
    terms read pointwise) ``rows.x`` holds the solved rows only; otherwise every sample up to
    the last solved row, and the columns pass through the output ``dynamics`` from sample
    ``start``."""
    if on_rows:
        out[...] = np.column_stack([t.columns(v, rows) for _, t, v, _, _ in inner])
        return
    # (a term's columns run from sample 0: only the output dynamics start late)
    cols = [t.columns(v, rows)[start:] for _, t, v, _, _ in inner]
    _dyn_rows(cols[0] if len(cols) == 1 else np.column_stack(cols), dynamics,
              rows.record.dt, rows.rows - start, out=out)


class _BankSet(NamedTuple):
    """The play banks (or Bouc-Wen banks) of one structure fit: ``raw`` per recording,
    ``banks`` (split into level segments on a Preisach base), the reduced basis ``V``
    (``None`` for a full fit); for a ranking solve of banks not in the cache
    (:func:`_sampled_banks`, then ``raw`` and ``banks`` are empty) the bank ``inputs`` and
    the bank rows the products start from, ``row0``; ``r_bank``: the thresholds of the
    bank's columns when the reduced products are formed along the input
    (:func:`bank_rows_times`), else ``None``."""

    raw: Sequence[np.ndarray]
    banks: Sequence[np.ndarray]
    V: np.ndarray | None
    inputs: list | None
    row0: list | None
    r_bank: np.ndarray | None
    #: a full fit of a bank too large to keep (:func:`_streams`): per recording the bank
    #: input and its row-0 state ``(w, z0)``, the plays streamed in row blocks; else None
    streamed: list[tuple[np.ndarray, np.ndarray]] | None = None


class _Banks(Sequence):
    """The play banks of a ranking solve (the first ``upto[k]`` rows of recording ``k``'s,
    :meth:`BankCache.bank`), each formed when first read. A bank in the cache is read at
    once (the cache's order of use stays that of reading them all); one that is not is
    neither kept nor counted by the cache, so it may wait until it is read."""

    def __init__(self, cache: BankCache, s: Structure, records: Sequence[Recording],
                 upto: list[int]) -> None:
        self._args = (cache, s, records, upto)
        r = np.asarray(s.thresholds)
        self._b: list[np.ndarray | None] = [
            self._form(k) if cache.has_bank(k, r, s.history[k], s.shape, s.beta_s) else None
            for k in range(len(records))]

    def _form(self, k: int) -> np.ndarray:
        cache, s, records, upto = self._args
        return cache.bank(k, records[k], np.asarray(s.thresholds), s.history[k], s.beta_s,
                          upto=upto[k], shape=s.shape)

    def __len__(self) -> int:
        return len(self._b)

    @overload
    def __getitem__(self, k: int) -> np.ndarray: ...

    @overload
    def __getitem__(self, k: slice) -> list[np.ndarray]: ...

    def __getitem__(self, k: int | slice) -> np.ndarray | list[np.ndarray]:
        if isinstance(k, slice):
            return [self[i] for i in range(len(self._b))[k]]
        B = self._b[k]
        if B is None:
            B = self._b[k] = self._form(k)
        return B


def _bank_set(cache: BankCache, s: Structure, records: Sequence[Recording],
              train: Sequence[np.ndarray], rows: list[np.ndarray], upto: list[int],
              starts: list[int], vkey: Any, rss_only: bool, reduce: bool) -> _BankSet:
    """The banks of :func:`fit_structure` (:class:`_BankSet`)."""
    r = np.asarray(s.thresholds)
    # a ranking solve of rate-independent plays whose bank is not kept (a history or loop
    # shape met once): the plays run along the input storing only the rows the reduced
    # basis and the products start from (_sampled_banks), not their (N, n) outputs
    sampled = (_sampled_banks(cache, s, records, train, rows, upto, starts, vkey)
               if rss_only and reduce and not s.levels and s.beta_s is None
               and not s.bouc_wen and not s.signed else None)
    inputs = row0 = streamed = None
    raw: Sequence[np.ndarray]
    banks: Sequence[np.ndarray]
    if sampled is not None:
        raw = banks = []
        V, inputs, row0 = sampled
    elif not rss_only and _streams(cache, s, records):
        raw = banks = []
        V = None
        streamed = [_bank_start(s, rec, k) for k, rec in enumerate(records)]
    elif rss_only and reduce and not s.levels and not s.bouc_wen:
        # (a bank not in the cache is formed when first read: not at all where the search's
        # products are still held, :meth:`BankCache.kept_product`)
        raw = banks = _Banks(cache, s, records, upto)
        V = None
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
    # are then formed along the input, bank_rows_times)
    r_bank = (np.r_[0.0, r] if V is not None and s.beta_s is None and not s.bouc_wen
              and not s.levels and not s.signed else None)
    return _BankSet(raw, banks, V, inputs, row0, r_bank, streamed)


def _pi_rows(bs: _BankSet, s: Structure, cache: BankCache, key: Any, idx: np.ndarray, last: int,
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
            out[...] = input_rows_times(bs.inputs[k][s0:last], bs.row0[k], V, filled(bs.r_bank),
                                         idx - s0)
        elif idx.size:
            _dyn_rows(input_rows_times(bs.inputs[k][s0:last], bs.row0[k], V, filled(bs.r_bank),
                                        np.arange(last - s0)),
                      s.dynamics, dt, idx - s0, out=out)
    elif V is not None and not s.dynamics:
        # only the solved rows are needed (a strided view when they are evenly spaced,
        # as in a single training window: the same product without gathering them)
        P = None if bs.r_bank is None else bank_rows_times(bs.banks[k], V, bs.r_bank, idx)
        out[...] = bs.banks[k][sel] @ V if P is None else P
    else:
        # (the dynamics run from where their start transient has died out by the first
        # solved row, not from sample 0: the same rows to round-off)
        plain = s.beta_s is None and not s.signed
        P = None if V is None else cache.kept_product(V, key, last, start, plain,
                                                      bs.r_bank is not None)
        if P is None:
            P = bs.banks[k][start:last] if V is None else cache.projected(
                bs.banks[k][:last], V, key, w=bs.raw[k][:last, 0] if plain else None,
                start=start, r=bs.r_bank)
        _dyn_rows(P, s.dynamics, dt, idx - start, out=out)


def _simulated(s: Structure, records: Sequence[Recording], train: Sequence[np.ndarray],
               banks: Sequence[np.ndarray], p0: float, pw: np.ndarray, coef: dict[str, Any],
               cache: BankCache) -> Fit:
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

def _stage_output(cache: BankCache, s: Structure, records: Sequence[Recording], k: int,
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
    if (s.beta_s is None and not s.bouc_wen and not s.signed
            and not cache.has_bank(k, r, hist, s.shape)):
        u, z0 = _bank_start(s, rec, k)
        return _streamed_product(u, z0, np.r_[0.0, r], s.levels, w, u.size)
    B = cache.bank(k, rec, r, hist, s.beta_s, shape=s.shape, bouc_wen=s.bouc_wen)
    return (cache.levelled(k, B, s) if s.levels else B) @ w


def _streams(cache: BankCache, s: Structure, records: Sequence[Recording]) -> bool:
    """Whether a full fit of ``s`` streams its play banks in row blocks instead of forming
    them (:func:`_streamed_rows`): rate-independent plays on a PI or Preisach base, banks
    not cached and together larger than the cache's budget
    (:func:`~.cache_budget.cache_budget` of the diagnosis's samples; a short recording is
    fitted from its whole bank, as before), and output dynamics that forget their start (a block's
    rows are those of the filter run from the first sample to round-off, as
    :func:`_filter_start`)."""
    if s.beta_s is not None or s.bouc_wen or s.signed:
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
    from state ``z0`` (split into the level segments of ``levels``, :func:`split_levels`), the
    plays run over blocks of :data:`STREAM_ROWS` rows with their state carried (the play
    update is exact: the rows of the whole bank), each block multiplied and dropped."""
    out = np.empty(upto)
    z = z0
    for a in range(0, upto, STREAM_ROWS):
        B, z = play_bank(w[a : min(a + STREAM_ROWS, upto)], r_full, z)
        out[a : a + B.shape[0]] = split_levels(B, levels) @ weights
    return out


def _streamed_rows(w: np.ndarray, r_full: np.ndarray, z0: np.ndarray, levels: tuple,
                   dyn: tuple, dt: float, idx: np.ndarray, start: int, out: np.ndarray) -> None:
    """Rows ``idx`` of the play bank of thresholds ``r_full`` on input ``w`` (state ``z0``
    before it; split into the level segments of ``levels``, :func:`split_levels`) through the
    output dynamics ``dyn`` started at row ``start``, written to ``out`` ``(idx.size,
    width)``, with at most :data:`STREAM_ROWS` plus the dynamics' warm-up of bank rows alive.

    Without dynamics the plays run storing only the rows ``idx`` (:func:`play_rows`, the
    bank's numbers). With them the solved rows go in groups of a block; the first group's
    filter starts at ``start`` (the rows of the whole bank's), each later group's where its
    start transient has died out by its first row (:func:`_filter_start`: the rows of the
    filter run from ``start`` to round-off), on bank rows kept from the block before."""
    if not idx.size:
        return
    if not dyn:
        B = play_rows(w, r_full, z0.copy(), np.asarray(idx, dtype=np.int64),
                       np.empty((idx.size, r_full.size)))
        out[...] = split_levels(B, levels)
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
        _dyn_rows(split_levels(have, levels), dyn, dt, group - s0, out=out[done:end])
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
        stop = hysteresis_model(loop_shape(s.shape), stop_model(gap, r, p0, pw, z0))
        # (the slip force by direction: the gain of each sign of the force after the bank)
        return stop if not s.signed else Chain.of(stop, SignedGain(1.0, signed_ratio(s.shape)))
    if s.bouc_wen and element_family(s.bouc_wen) == MP:
        # weights >= 0 on the clockwise or counter-clockwise columns; the virtual history
        # (on the mapped input) is the model's own
        hyst = menegotto_pinto_model(max(p0, 0.0), np.maximum(pw, 0.0), s.bouc_wen,
                                     apply_shape(s.shape, np.asarray(s.history[k]))
                                     if s.history[k] else None)
        if s.shape:
            hyst = hysteresis_model(s.shape, hyst)
    elif s.bouc_wen:
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
