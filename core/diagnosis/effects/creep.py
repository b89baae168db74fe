"""Logarithmic creep: a bank of slow lags, one per decade of time."""

from __future__ import annotations

import numpy as np

from ...stages import Creep, foh_filter
from ..candidates import Candidate
from ..context import FitContext
from ..periodic import cycle_to_cycle
from ..registry import DiagnosableEffect, SignatureRows, StaticTerm, TermRows, register
from ..structure import Fit


def _columns(taus: tuple[float, ...], rows: TermRows) -> np.ndarray:
    """``L_tau[x] - x`` per time constant of the bank: the PI-stage output ``x`` through a
    unit lag (first-order hold, from the steady state of its first sample) minus itself."""
    x = rows.x
    assert x is not None
    return np.column_stack([foh_filter(x, [1.0], [tau, 1.0], rows.record.dt)[0] - x
                            for tau in taus])


TERM = StaticTerm(
    off=(),
    width=lambda taus, n_records: len(taus),
    columns=_columns,
    coefficients=lambda taus, w, fit: w,
    stage=lambda taus, w, k, record: Creep(np.asarray(taus, dtype=np.float64), np.maximum(w, 0.0)),
    lower=0.0,
    through_dynamics=True,
    sample_spacing=True,
    bank=True,
    refit_parameters=lambda taus, w: {"gamma_per_decade": float(w.sum() / len(taus))},
)


def _has_hold(ctx: FitContext) -> bool:
    """Whether a hold (>= 0.5 s) after an input change lies inside the train or test rows."""
    return any((tr | te)[h0 : h0 + n].any()
               for c, tr, te in zip(ctx.coords, ctx.train, ctx.test, strict=True)
               for h0, n, _ in c.holds)


def _untestable(ctx: FitContext) -> str | None:
    """Creep needs a hold (>= 0.5 s) after an input change (a step or a ramp: the creep /
    relaxation test) inside the train or test rows, or a single recording whose input
    repeats one cycle, judged from cycle to cycle (:func:`cycle_signature`: the settling of its
    slow lags after the input's last change)."""
    if _has_hold(ctx) or cycle_signature(ctx) is not None:
        return None
    return ("no hold of >= 0.5 s after an input change (a step or a ramp) inside the "
            "train/test rows, and no single recording repeating one input cycle whose test "
            "rows are compared from cycle to cycle")


def cycle_signature(ctx: FitContext) -> SignatureRows | None:
    """Without a hold, where creep shows apart from the model's bias: under a repeated
    input the slow lags of the bank settle after the input's last change (a jump, the
    start) while a rate-independent base repeats itself, so the settling shows as a change
    from cycle to cycle that decays (:func:`~core.diagnosis.periodic.cycle_to_cycle`; a
    drift's is steady). ``None`` with a hold (every test row as before: the relaxation
    after the steps is the signature) and with explicit windows (strict hold-out: the
    evidence is the cross-fitted training blocks, where the base's misfit does not cancel)."""
    if ctx.strict or _has_hold(ctx):
        return None
    return cycle_to_cycle(ctx.records)


#: The block inside a hold whose residual means are compared (:func:`hold_signature`), as a
#: share of the bank's fastest lag (at least one sample of its recording): the lag itself,
#: 10 ms of a bank from 10 ms, 10 rows at 1 kHz. The bank holds nothing faster than its
#: fastest lag; a block as long shows every lag of the bank move from one block to the next
#: while its mean cuts the noise by its rows. With a tenth of it (one row at 1 kHz) the
#: family's small creep (2 % of a step at 0.2 % noise) on the Bouc-Wen n = 2 plant was not
#: named: changes between single rows carry two rows' noise.
HOLD_BLOCK_SHARE = 1.0


def hold_signature(ctx: FitContext) -> SignatureRows | None:
    """With a hold, where creep shows apart from the model's bias: inside the holds after
    input changes (:func:`_has_hold`) the input's value and history do not change, so a
    rate-independent base holds its output still and its misfit, however large, stays
    what it was, while the output keeps creeping, about linearly in log(time). Each hold is
    cut into consecutive blocks as long as the bank's fastest lag (:data:`HOLD_BLOCK_SHARE`),
    and the residual's mean over each block is compared with its mean over the block at half
    its time into the hold (:attr:`~core.diagnosis.registry.SignatureRows.block`,
    ``previous``): an octave of hold time apart, over which a logarithmic creep moves the
    output by the same amount wherever in the hold, and each block the reference of two
    others at most. Blocks as long as the bank's fastest lag keep the motion of each of its
    lags while their means cut the noise (a change between two single rows carries two
    rows' noise, which buries a creep of a few per cent of a step). ``None`` without a hold
    and with explicit windows (strict hold-out: the evidence is the cross-fitted training
    blocks)."""
    if ctx.strict or not _has_hold(ctx):
        return None
    fastest = min(bank_taus(ctx), default=0.0)
    masks, previous, blocks = [], [], []
    for r, c in zip(ctx.records, ctx.coords, strict=True):
        block = max(1, int(round(HOLD_BLOCK_SHARE * fastest / r.dt)))
        m = np.zeros(r.n_samples, dtype=bool)
        prev = np.full(r.n_samples, -1, dtype=np.int64)
        for h0, n, _ in c.holds:
            ends = np.arange(h0 + block - 1, h0 + n, block)  # each block's last row
            k = np.arange(1, ends.size)
            m[ends[k]] = True
            prev[ends[k]] = ends[k // 2]  # the block at half its time into the hold
        masks.append(m)
        previous.append(prev)
        blocks.append(block)
    n_holds = sum(len(c.holds) for c in ctx.coords)
    return SignatureRows(masks, f"inside the {n_holds} hold{'s' if n_holds != 1 else ''} "
                                f"after input changes (the residual's mean over "
                                f"{1000 * HOLD_BLOCK_SHARE * fastest:.3g} ms blocks, each "
                                f"against the block at half its time into the hold)",
                         previous=previous, block=tuple(blocks), beyond_history=True)


def _signature(ctx: FitContext) -> SignatureRows | None:
    """Where creep is judged: inside the holds (:func:`hold_signature`), else from cycle to
    cycle of a repeated input (:func:`cycle_signature`), else every test row."""
    return hold_signature(ctx) or cycle_signature(ctx)


def bank_taus(ctx: FitContext) -> tuple[float, ...]:
    """The bank's time constants (s): one per decade from 10 dt (>= 10 ms) to the record
    length (judged from cycle to cycle, :func:`cycle_signature`: to the decade at or above
    it); empty when the record is shorter than the first."""
    dt = min(r.dt for r in ctx.records)
    lo = max(10 * dt, 0.01)
    hi = max(r.t[-1] - r.t[0] for r in ctx.records)
    if cycle_signature(ctx) is not None:
        # from cycle to cycle the settling of lags of the record's length shows (a lag
        # between the last decade below it and the record's length, a 3 s lag in an 8 s
        # record, has no column of its curvature otherwise)
        hi = 10.0 ** np.ceil(np.log10(hi))
    return tuple(float(x) for x in 10.0 ** np.arange(np.ceil(np.log10(lo)),
                                                     np.log10(hi) + 1e-9))


def _build(ctx: FitContext, cur: Fit) -> Candidate | None:
    """Creep lag bank of :func:`bank_taus`."""
    s = cur.structure
    if s.term("creep"):
        return None
    taus = bank_taus(ctx)
    if len(taus) < 1:
        return None
    fit = ctx.fit(s.with_term("creep", taus), cur)
    w = fit.terms["creep"]
    return fit, {"taus_s": list(taus), "weights": w.tolist(),
                 "gamma_per_decade": float(w.sum() / len(taus))}, {}


#: Shift (decades) of the two creep banks the accepted creep is refitted with to measure how
#: much its total depends on where the bank's one-per-decade time constants fall.
BANK_SHIFT_DECADES = 0.5


def _bank_spread(ctx: FitContext, cur: Fit, fit: Fit) -> tuple[dict[str, float], str]:
    """Systematic sigma of the creep per decade: the accepted creep refitted with its bank
    shifted half a decade down and up (same number of lags); the largest change of the total
    (sum of the weights), per lag. A one-per-decade bank holds a relaxation time between its
    lags only approximately (a 5 ms lag on a bank from 10 ms), which the noise-driven
    jackknife does not see."""
    taus = fit.structure.term("creep")
    total = float(np.sum(fit.terms["creep"]))
    dev = 0.0
    for sh in (-BANK_SHIFT_DECADES, BANK_SHIFT_DECADES):
        alt = ctx.fit(fit.structure.with_term("creep", tuple(t * 10.0**sh for t in taus)), cur)
        dev = max(dev, abs(float(np.sum(alt.terms["creep"])) - total))
    return ({"gamma_per_decade": dev / len(taus)},
            f"widened by the change of the creep total with the bank shifted by "
            f"{BANK_SHIFT_DECADES:g} decade ({dev:.3g})")


register(DiagnosableEffect(
    "creep",
    family="slow",
    explanation=(
        'Logarithmic creep: after each input change the output keeps moving in the '
        'direction of that change, about linearly in log(time), modelled by a bank of '
        'slow lags.'
    ),
    parameter_words=(
        ("gamma_per_decade", "creep per decade of time (a fraction of a step)", ""),
    ),
    equation="y = x + sum_j c_j (L_tau_j[x] - x),  tau_j L' + L = x",
    experiment='an up-then-down staircase with holds of 3-30 s (>= 2 decades of hold time)',
    time_dependent=True,
    build=_build,
    model_type=Creep,
    structure_field="terms",
    term=TERM,
    untestable=_untestable,
    signature=_signature,
    linear=True,
    stage_order=3,
    sign_locked=True,
    systematic=_bank_spread,
    mimicked_by=(frozenset({"lag", "delay", "drift"}), "without holds, creep shows only as "
                 "something else: the fast end of its relaxation spectrum acts as a lag at the "
                 "excitation frequency, its slow tail after the last step as a trend from "
                 "cycle to cycle, like a drift; creep itself was untestable"),
    partly_tested=lambda ctx: None if cycle_signature(ctx) is None else (
        "without holds, creep was tested only from cycle to cycle of the repeated input, "
        "where only the settling of its slow lags shows: its fast end (lags shorter than "
        "the period) repeats with every cycle and acts as a lag at the excitation frequency, "
        "and a lag as long as the record settles as a steady trend, like a drift; {best} "
        "may be such a part of creep"),
    deciding=(
        ("drift", "an up-then-down staircase with holds of 3-30 s (creep follows "
         "the sign of the last step, drift does not)"),
    ),
    history_experiment="holds after input steps",
))
