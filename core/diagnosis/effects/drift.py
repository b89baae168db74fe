"""A slow additive drift in absolute time (Legendre polynomials per recording)."""

from __future__ import annotations

import numpy as np

from ...base import Chain, Model
from ...stages import Drift
from ..candidates import Candidate
from ..context import FitContext
from ..periodic import (
    MIN_CYCLES,
    MIN_SAME_BRANCHES,
    cycle_to_cycle,
    longest_repeating_run,
    repeated_cycles,
    same_history,
)
from ..registry import DiagnosableEffect, SignatureRows, StaticTerm, TermFit, TermRows, register
from ..structure import Fit, legendre_columns

#: A single recording shorter than this (s) cannot test a drift: a polynomial in time over
#: a short record is absorbed by the bias and slow noise.
SINGLE_DRIFT_S = 60.0


def _untestable(ctx: FitContext) -> str | None:
    """A drift must repeat across recordings, span minutes (:data:`SINGLE_DRIFT_S`), or show
    from cycle to cycle of a repeated input (:func:`~core.diagnosis.periodic.repeated_cycles`:
    after the first cycle a rate-independent model repeats itself, so a trend between the
    cycles is not the model's bias) or between branches of the same input history
    (:func:`~core.diagnosis.periodic.same_history`: a tapered sine's cycles at the same
    amplitude)."""
    total = sum(float(r.t[-1] - r.t[0]) for r in ctx.records)
    if total >= SINGLE_DRIFT_S or len(ctx.records) != 1:
        return None
    r = ctx.records[0]
    if repeated_cycles(r.u) or same_history(ctx.records, ctx.unsettled_memory) is not None:
        return None
    if ctx.unsettled_memory and same_history(ctx.records) is not None:
        return (f"the single {total:.3g} s record revisits the input history of earlier "
                "branches only once each, and its loops depart from Masing's rule (the branch "
                "after a reversal is not the first loading doubled) beyond the noise, which "
                "the base model cannot follow: on a history's first return the plant's memory "
                "may still be settling from the excursions before it, a change a slow drift "
                "would also make, so the two cannot be told apart (each input cycle repeated "
                "three times, or several recordings, would separate them)")
    run = longest_repeating_run(r.u)
    if len(run) >= 2:
        # the input does repeat, but too few times for a trend (the first cycle sets the
        # memory; a trend needs two changes between the cycles after it)
        return (f"the single {total:.3g} s record repeats its input cycle only {len(run)} times "
                f"(t = {r.t[run[0][0]]:.3g} to {r.t[min(run[-1][1], r.n_samples - 1)]:.3g} s); "
                f"a trend from cycle to cycle needs {MIN_CYCLES} identical cycles (the first "
                f"sets the memory), nor do {MIN_SAME_BRANCHES} of its branches revisit the input "
                "history of an earlier one, so a slow drift cannot be told from the model's "
                "bias and from slow sensor noise")
    return (f"a single {total:.3g} s record without a repeated input cycle cannot separate "
            "a slow drift from the model's bias and from slow sensor noise (a drift must "
            "repeat across recordings, show from one identical input cycle to the next, "
            "or span minutes)")


def _signature(ctx: FitContext) -> SignatureRows | None:
    """Where a drift shows apart from the model's bias: from cycle to cycle of one recording
    repeating its input (:func:`~core.diagnosis.periodic.cycle_to_cycle`, the rows creep is
    judged on too), else between the branches of the recordings that revisit an earlier
    branch's input history (:func:`~core.diagnosis.periodic.same_history`: a base that
    misses the loop misses it the same way on both, a drift does not); ``None`` (every test
    row) when no input revisits its history often enough."""
    return cycle_to_cycle(ctx.records) or same_history(ctx.records, ctx.unsettled_memory)


def _columns(degree: int, rows: TermRows) -> np.ndarray:
    """Legendre polynomials of degree 1 to ``degree`` in the recording's time, in its own
    block of ``degree`` columns (zero in the other recordings' blocks)."""
    out = np.zeros((rows.rows.size, degree * rows.fit.n_records))
    c0 = rows.k * degree
    out[:, c0 : c0 + degree] = legendre_columns(rows.record.t, degree)[rows.rows]
    return out


def _coefficients(degree: int, w: np.ndarray, fit: TermFit) -> list[np.ndarray]:
    """The coefficients per recording."""
    return [w[k * degree : (k + 1) * degree] for k in range(fit.n_records)]


TERM = StaticTerm(
    off=0,
    width=lambda degree, n_records: degree * n_records,
    columns=_columns,
    coefficients=_coefficients,
    stage=lambda degree, c, k, record: Drift(c[k], float(record.t[-1] - record.t[0])),
    per_recording=True,
    level_degree=lambda degree: degree,
    # an unseen recording's own drift is unknown: none
    unseen=lambda degree, c, j: [np.zeros_like(a) if k == j else a for k, a in enumerate(c)],
)


def _drift_stage(model: Model) -> Drift:
    """The drift stage that a model fitted with the drift term ends with."""
    stage = model.stages[-1] if isinstance(model, Chain) else model
    if not isinstance(stage, Drift):  # pragma: no cover - build_model puts it last
        raise TypeError(f"expected the drift stage last, got {stage.type_name!r}")
    return stage


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Legendre drift of degree 2 in absolute time per recording."""
    s = cur.structure
    if s.term("drift"):
        return None
    fit = ctx.fit(s.with_term("drift", 2), cur)
    return fit, {"coefficients": [c.tolist() for c in fit.terms["drift"]],
                 "peak_to_peak": [float(np.ptp(_drift_stage(m).drift(r.t - r.t[0])))
                                  for m, r in zip(fit.models, ctx.records, strict=True)]}, {}


register(DiagnosableEffect(
    "drift",
    family="slow",
    explanation=(
        'A slow additive drift in absolute time (thermal expansion, sensor zero drift), '
        'continuous across steps and independent of the step direction.'
    ),
    parameter_words=(
        ("coefficients", "drift coefficients", "output"),
        ("peak_to_peak", "drift peak to peak, per recording", "output"),
    ),
    equation='y = x + sum_k a_k P_k(2 t / T - 1)  (Legendre polynomials)',
    experiment=(
        'a record of several minutes, or an identical 1 Hz reference cycle repeated '
        'every 60 s over >= 5 min'
    ),
    time_dependent=True,
    lookalikes=("offset",),
    build=_build,
    model_type=Drift,
    structure_field="terms",
    term=TERM,
    untestable=_untestable,
    signature=_signature,
    linear=True,
    stage_order=6,
    history_experiment="an identical input cycle repeated over the record",
))
