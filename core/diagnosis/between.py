"""Evidence between recordings: each recording predicted from the others.

A rate-dependent effect changes the loop from one excitation rate to the next, an
amplitude-dependent one (a static output map, a loop-shape nonlinearity) from one input
amplitude to the next. With several short periodic recordings (or closed loops) at different
frequencies or amplitudes, the honest test of such an effect is whether a model fitted on the
other recordings (its nonlinear parameters searched there too) predicts the held-out
recording better than the current model fitted on the same others. The held-out recording is
never used for selection. :func:`between_plan` says which of the two tests apply, and why
not when they do not.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import Float1D
from ..fitting.metrics import percent_of_range
from ..fitting.steadystate import steady_state_history
from ..fitting.thresholds import reversal_indices
from .candidates import build_candidate
from .context import FitContext
from .registry import EFFECTS
from .stats import HeldOut, heldout_comparison
from .structure import Fit, Structure, build_model, legendre_columns

__all__ = ["LORO_RULE", "NONLINEAR_PARAMS", "SHARED_RULE", "BetweenPlan", "amplitudes_differ",
           "between_plan", "between_recordings", "leave_one_recording_out", "recording_amplitudes",
           "recording_rates", "rates_differ"]

#: The leave-one-recording-out variant that judges whether a per-recording effect (an offset,
#: a drift) generalises (acceptance rule 8): its values cannot be known for an unseen
#: recording, so every structure compared gets the left-out recording's own level.
SHARED_RULE = (
    "each recording in turn is predicted by the structure refitted on the other recordings, "
    "with its own level (offset and a drift of the same degree, fitted on its own rows) for "
    "every structure compared alike: only what the recordings share is judged"
)

#: Per-recording excitation rates must span this factor for a between-recordings test.
MIN_RATE_RATIO = 1.5

#: Per-recording input amplitudes (peak to peak) must span this factor for the
#: between-recordings test of amplitude-dependent effects.
MIN_AMPLITUDE_RATIO = 1.5

#: A travel between reversals is large when it exceeds this share of the recording's input
#: range; reversals are counted from :data:`REVERSAL_SHARE` of it, and a travel that is more
#: than :data:`MAX_HOLD_SHARE` holds has no rate.
TRAVEL_SHARE = 0.2
REVERSAL_SHARE = 0.01
MAX_HOLD_SHARE = 0.1
#: A recording excites one rate when at least :data:`ONE_RATE_SHARE` of its large travels
#: are within :data:`ONE_RATE_TOL` of their median rate (tapered starts and ends allowed),
#: one amplitude when every large travel is within :data:`ONE_AMPLITUDE_TOL` of the median.
ONE_RATE_TOL = 0.25
ONE_RATE_SHARE = 2 / 3
ONE_AMPLITUDE_TOL = 0.1

#: Nonlinear parameters whose agreement across folds (or left-out recordings) is checked;
#: linear weights and data-derived scalings (an output map's centre and scale) are not.
NONLINEAR_PARAMS = ("delay_s", "tau_s", "freq_hz", "damping", "beta_s")

#: How :func:`leave_one_recording_out` treats what belongs to one recording.
LORO_RULE = (
    "each recording in turn is predicted (all its rows) by the structure refitted (linear "
    "weights) on the train and test rows of the other recordings; the nonlinear parameters "
    "(delay, time constants, beta, ...) stay at the values the diagnosis found; what belongs "
    "to one recording cannot be learnt for an unseen one: the held-out recording starts from "
    "the virgin memory state (a periodic steady-state recording from the memory its own cycle "
    "leaves), gets no drift, and its offset is the mean of the others'"
)


def recording_rates(ctx: FitContext) -> list[list[float]]:
    """Mean input rate |Δu|/Δt (input units/s) of each large travel between reversals
    (> 20 % of the recording's input range, not mostly a hold), per recording."""
    out = []
    for rec, c in zip(ctx.records, ctx.coords, strict=True):
        span = float(np.ptp(rec.u)) or 1.0
        rv = reversal_indices(rec.u, REVERSAL_SHARE * span)
        rv = np.concatenate((rv, [rec.n_samples - 1]))
        peaks = []
        for a, b in zip(rv[:-1], rv[1:], strict=True):
            if (abs(rec.u[b] - rec.u[a]) > TRAVEL_SHARE * span and b > a + 2
                    and c.hold[a:b].mean() < MAX_HOLD_SHARE):
                peaks.append(abs(float(rec.u[b] - rec.u[a])) / ((b - a) * rec.dt))
        out.append(peaks)
    return out


def rates_differ(ctx: FitContext) -> bool:
    """Several timed recordings, each at one rate (at least 2/3 of its travels within
    ±25 % of its median rate: tapered starts and ends allowed), whose median rates span at
    least :data:`MIN_RATE_RATIO` between recordings.

    Recordings that each sweep several rates (a multisine, a staircase) keep the test rows
    inside every recording as evidence: predicting the one recording that excites fast
    dynamics from the others would test extrapolation, not the effect.
    """
    if len(ctx.records) < 2 or not all(r.has_time for r in ctx.records):
        return False
    rates = recording_rates(ctx)
    if not all(_one_rate(p) for p in rates):
        return False
    med = [float(np.median(p)) for p in rates]
    return max(med) >= MIN_RATE_RATIO * max(min(med), 1e-300)


def recording_amplitudes(ctx: FitContext) -> list[list[float]]:
    """Input excursion |Δu| (input units) of each large travel between reversals (> 20 % of
    the recording's input range), per recording."""
    out = []
    for rec in ctx.records:
        span = float(np.ptp(rec.u)) or 1.0
        rv = np.concatenate(([0], reversal_indices(rec.u, REVERSAL_SHARE * span),
                             [rec.n_samples - 1]))
        out.append([abs(float(rec.u[b] - rec.u[a])) for a, b in zip(rv[:-1], rv[1:], strict=True)
                    if abs(rec.u[b] - rec.u[a]) > TRAVEL_SHARE * span])
    return out


def amplitudes_differ(ctx: FitContext) -> tuple[bool, str]:
    """Several recordings, each of one input amplitude (every large travel within ±10 % of
    its median: a periodic recording or a closed loop), whose amplitudes span at least
    :data:`MIN_AMPLITUDE_RATIO`. Returns whether they do, and why not in words."""
    if len(ctx.records) < 2:
        return False, "a single recording"
    amps = recording_amplitudes(ctx)
    several = [r.name for r, a in zip(ctx.records, amps, strict=True) if not _one_amplitude(a)]
    if several:
        return False, (f"{', '.join(several)} {'sweeps' if len(several) == 1 else 'sweep'} "
                       "several amplitudes (a decaying sine, a staircase), so the rows inside "
                       "each recording are the evidence")
    med = [float(np.median(a)) for a in amps]
    if max(med) < MIN_AMPLITUDE_RATIO * max(min(med), 1e-300):
        return False, (f"the recordings share one input amplitude (within a factor "
                       f"{MIN_AMPLITUDE_RATIO:g})")
    return True, ""


def _one_amplitude(a: list[float]) -> bool:
    if not a:
        return False
    m = float(np.median(a))
    return bool(np.all(np.abs(np.asarray(a) - m) <= ONE_AMPLITUDE_TOL * m))


@dataclass(frozen=True)
class BetweenPlan:
    """Which effects are judged by predicting each recording from the others.

    Attributes
    ----------
    rate, amplitude : bool
        Rate-dependent (recordings at different rates) / amplitude-dependent effects
        (recordings at different amplitudes) are judged between recordings.
    rate_reason, amplitude_reason : str
        Why not, in words (empty when they are).
    """

    rate: bool
    amplitude: bool
    rate_reason: str
    amplitude_reason: str

    def to_dict(self) -> dict[str, Any]:
        """JSON form: ``{"rate": {"tested", "reason"}, "amplitude": {"tested", "reason"}}``."""
        return {"rate": {"tested": self.rate, "reason": self.rate_reason},
                "amplitude": {"tested": self.amplitude, "reason": self.amplitude_reason}}


def between_plan(ctx: FitContext, windows: bool) -> BetweenPlan:
    """The between-recordings tests that apply (none with explicit train/test ``windows``:
    the others' test rows would be fitted)."""
    if windows:
        why = "explicit train/test windows (the other recordings' test rows would be fitted)"
        return BetweenPlan(False, False, why, why)
    rate = rates_differ(ctx)
    amp, amp_why = amplitudes_differ(ctx)
    rate_why = "" if rate else (
        "a single recording" if len(ctx.records) < 2 else
        "some recordings have no time axis" if not all(r.has_time for r in ctx.records) else
        "the recordings do not each excite one rate, at rates at least "
        f"{MIN_RATE_RATIO:g}x apart")
    return BetweenPlan(rate, amp, rate_why, amp_why)


def _one_rate(p: list[float]) -> bool:
    if not p:
        return False
    m = float(np.median(p))
    return float(np.mean(np.abs(np.asarray(p) - m) <= ONE_RATE_TOL * m)) >= ONE_RATE_SHARE


def _others(ctx: FitContext, j: int) -> list[np.ndarray]:
    return [np.zeros(r.n_samples, dtype=bool) if k == j else (tr | te)
            for k, (r, tr, te) in enumerate(zip(ctx.records, ctx.train, ctx.test, strict=True))]


def left_out_residual(ctx: FitContext, s: Structure, j: int,
                      own_level: int | None = None) -> Float1D:
    """Residual on every row of recording ``j`` of structure ``s`` refitted (linear weights)
    on the train and test rows of the other recordings (rule: :data:`LORO_RULE`).

    With ``own_level`` (a Legendre degree, 0 = a constant), the level of recording ``j`` (its
    own offset and a drift of that degree in time) is fitted on its own rows instead, for
    every structure alike: what is compared is then only the shared part of the model
    (:data:`SHARED_RULE`)."""
    recs = ctx.records
    rec = recs[j]
    # a periodic steady-state recording keeps the memory its own cycle leaves
    own = s.history[j] if s.history[j] and s.history[j] == steady_state_history(rec) else ()
    sj = s.with_(history=tuple(own if k == j else h for k, h in enumerate(s.history)))
    # fitted as the diagnosis fits it (FitContext.fit): a term judged on changes between
    # rows of the same input history (creep inside the holds, a drift from cycle to cycle)
    # has its weights from those changes of the other recordings, not from their raw rows,
    # where its columns would also take the base's misfit
    others = FitContext(recs, _others(ctx, j), [np.zeros(r.n_samples, dtype=bool)
                                                for r in recs], parent=ctx)
    f = others.fit(sj)
    # the static terms' own coefficients of recording j (a level) are unknown to the fit
    coef = {}
    for name, c in f.terms.items():
        t = EFFECTS[name].term
        assert t is not None
        coef[name] = c if t.unseen is None else t.unseen(sj.term(name), c, j)
    model = build_model(sj, j, f.p0, f.weights, coef, rec)
    e = rec.y - model(rec.u, dt=rec.dt)
    if own_level is None:
        return e
    X = np.ones((rec.n_samples, 1))
    if own_level > 0:
        X = np.column_stack((X, legendre_columns(rec.t, own_level)))
    return e - X @ np.linalg.lstsq(X, e, rcond=None)[0]


def leave_one_recording_out(ctx: FitContext, s: Structure, own_level: int | None = None
                            ) -> dict[str, Any]:
    """Leave-one-recording-out score of structure ``s`` (rule: :data:`LORO_RULE`; with
    ``own_level``, :data:`SHARED_RULE`, see :func:`left_out_residual`).

    Returns
    -------
    dict
        ``{"rule", "rmse", "rmse_pct", "per_recording": [{"recording", "samples", "rmse",
        "rmse_pct"}]}``; RMSE in output units, ``_pct`` in % of the output range of the
        scored rows (all rows of all recordings); ``rmse`` pools every sample of every recording.
    """
    recs = ctx.records
    yr = 100.0 / percent_of_range(1.0, [r.y for r in recs])  # every row is scored
    per = []
    sse = 0.0
    n_all = 0
    for j, rec in enumerate(recs):
        e = left_out_residual(ctx, s, j, own_level)
        ej = float(e @ e)
        sse += ej
        n_all += rec.n_samples
        rm = float(np.sqrt(ej / rec.n_samples))
        per.append({"recording": rec.name, "samples": rec.n_samples, "rmse": rm,
                    "rmse_pct": 100 * rm / yr})
    rmse = float(np.sqrt(sse / max(n_all, 1)))
    return {"rule": LORO_RULE if own_level is None else SHARED_RULE, "rmse": rmse,
            "rmse_pct": 100 * rmse / yr, "per_recording": per}


@dataclass(frozen=True, eq=False)
class BetweenRecordings:
    """The leave-one-recording-out test of one effect (:func:`between_recordings`).

    Attributes
    ----------
    pooled : HeldOut
        The comparison over every left-out recording's rows.
    per_recording : list of dict
        ``{"recording", "parameters", "mse_reduction"}`` per left-out recording (report rows).
    parameter_cv : dict of str to float
        Coefficient of variation of each nonlinear parameter over the recordings.
    folds : int
        Number of recordings.
    before, after : list of ndarray
        Each left-out recording's residual without / with the effect.
    """

    pooled: HeldOut
    per_recording: list[dict[str, Any]]
    parameter_cv: dict[str, float]
    folds: int
    before: list[Float1D]
    after: list[Float1D]


def between_recordings(ctx: FitContext, name: str, cur: Fit) -> BetweenRecordings | None:
    """Leave-one-recording-out test of effect ``name`` on top of ``cur``.

    For each recording ``j``: the current structure is refitted on the other recordings, the
    effect's nonlinear parameters are searched on the others' training rows only
    (:func:`~core.diagnosis.candidates.build_candidate` on a context without ``j``), and both
    structures, refitted on the others' rows, predict every row of ``j``.

    Returns
    -------
    BetweenRecordings or None
        None when the effect does not apply on some subset.
    """
    recs = ctx.records
    before: list[Float1D] = []
    after: list[Float1D] = []
    per: list[dict[str, Any]] = []
    params: list[dict[str, Any]] = []
    for j, rec in enumerate(recs):
        none = np.zeros(rec.n_samples, dtype=bool)
        tr = [none if k == j else m for k, m in enumerate(ctx.train)]
        te = [none if k == j else m for k, m in enumerate(ctx.test)]
        sub = FitContext(recs, tr, te, parent=ctx)
        got = build_candidate(sub, name, sub.fit(cur.structure, cur))
        if got is None:
            return None
        fit, p, _ = got
        e0 = left_out_residual(ctx, cur.structure, j)
        e1 = left_out_residual(ctx, fit.structure, j)
        before.append(e0)
        after.append(e1)
        params.append(p)
        per.append({"recording": rec.name, "parameters": p,
                    "mse_reduction": 1.0 - float(e1 @ e1) / max(float(e0 @ e0), 1e-300)})
    cv: dict[str, float] = {}
    for key in (k for k in params[0] if k in NONLINEAR_PARAMS):
        v = np.array([q[key] for q in params if isinstance(q.get(key), int | float)], float)
        if v.size == len(params) and np.all(np.isfinite(v)):
            m = float(np.mean(np.abs(v)))
            cv[key] = float(np.std(v, ddof=1) / m) if m > 0 else 0.0
    pooled: HeldOut = heldout_comparison(before, after)
    return BetweenRecordings(pooled=pooled, per_recording=per, parameter_cv=cv,
                             folds=len(recs), before=before, after=after)
