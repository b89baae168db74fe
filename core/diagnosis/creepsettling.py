"""Creep without a hold: how large a creep one repeated-cycle recording could have shown.

Creep lives in the holds after input changes (the output keeps moving while the input rests,
notes §4). A recording without such a hold, one input step followed by a repeated cycle (the
shipped piezo recording: a jump at 3.26 s, then a 1 Hz sine), shows it only in three places,
and none of them is enough for a name:

* the lags of the creep bank shorter than the input's period repeat with every cycle: at one
  excitation rate they act as loop width and a phase lag, which the base and a lag take;
* the settling right after the one step is one event, fewer than the independent events a
  dynamic name needs (:attr:`~core.diagnosis.acceptance.AcceptRule.min_events`);
* the lags as long as the period or longer keep settling after the step, which shows as a
  change from one cycle to the next (:func:`~core.diagnosis.periodic.cycle_to_cycle`), the
  one place creep is tested here. That change is small: the lags' settling between two
  cycles late in the record, against the recording's own change from cycle to cycle.

When that test finds nothing, the report says so, with the smallest creep it could have
found (:func:`settling_limit`): a creep of ``gamma`` per decade adds ``gamma * dL`` to the
residual's changes from cycle to cycle (``dL``: the change of the bank's slow lags, applied
to the model's prediction, one cycle apart); fitted on those changes it removes the share
``gamma^2 |dL|^2 / (|de|^2 + gamma^2 |dL|^2)`` of their MSE (``de``: the residual's own
changes), which reaches the acceptance rule's ``min_gain`` at
``gamma = sqrt(min_gain / (1 - min_gain) * |de|^2 / |dL|^2)``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .._typing import Float1D
from ..stages import foh_filter
from .acceptance import RULE
from .context import FitContext
from .effects.creep import bank_taus, cycle_signature
from .events import step_starts
from .results import RoundRow
from .specs import Untestable
from .structure import Fit

__all__ = ["CREEP", "PLAUSIBLE_CREEP", "settling_limit", "untested_entry"]

#: The creep effect's name.
CREEP = "creep"
#: Largest creep per decade of time (a fraction of the last step) a device is expected to
#: show (notes §E5: 0.1-3 % per decade; about 1 % for a piezo stack). When the cycle-to-cycle
#: test could not have found a creep this large, creep is untestable on the recording; when
#: it could, its finding nothing is a negative result and no entry is made.
PLAUSIBLE_CREEP = 0.03


def settling_limit(pred: Sequence[Float1D], res: Sequence[Float1D],
                   pairs: Sequence[tuple[np.ndarray, np.ndarray]], taus: Sequence[float],
                   dt: Sequence[float], min_gain: float = RULE.min_gain) -> float:
    """Smallest creep per decade whose settling from cycle to cycle would lower the MSE of
    the residual's changes by ``min_gain`` (module docstring).

    Parameters
    ----------
    pred : sequence of ndarray, each of shape (n_k,)
        The model's prediction per recording (output units): what the creep bank acts on.
    res : sequence of ndarray, each of shape (n_k,)
        The residual per recording (output units).
    pairs : sequence of (ndarray of int, ndarray of int)
        Per recording, the rows compared and the rows one cycle earlier, as two index arrays
        of the same length.
    taus : sequence of float
        The slow lags of the bank (s), each weighted ``gamma`` (a fraction of a step).
    dt : sequence of float
        Sampling interval per recording (s).
    min_gain : float
        Share of the changes' MSE the creep must remove.

    Returns
    -------
    float
        ``gamma`` (a fraction of a step per decade); ``inf`` when the lags do not change
        from cycle to cycle over the pairs (or there are no pairs or no lags), ``0`` when the
        residual does not change.
    """
    if not len(taus):
        return math.inf
    dl2, de2, n = 0.0, 0.0, 0
    for p, e, (a, b), h in zip(pred, res, pairs, dt, strict=True):
        if not len(a):
            continue
        x = np.asarray(p, dtype=np.float64)
        lag = np.sum([foh_filter(x, [1.0], [tau, 1.0], h)[0] for tau in taus], axis=0)
        dl2 += float(np.sum((lag[a] - lag[b]) ** 2))
        de2 += float(np.sum((np.asarray(e)[a] - np.asarray(e)[b]) ** 2))
        n += len(a)
    if n == 0 or dl2 <= 0.0:
        return math.inf
    return math.sqrt(min_gain / (1.0 - min_gain) * de2 / dl2)


def _pairs(previous: Sequence[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per recording, the rows of a cycle-to-cycle signature and the rows one cycle before."""
    out = []
    for prev in previous:
        t = np.flatnonzero(prev >= 0)
        out.append((t, prev[t]))
    return out


def _period_s(ctx: FitContext, pairs: Sequence[tuple[np.ndarray, np.ndarray]]) -> float:
    """The input's period (s): the median spacing of the compared rows."""
    spans = [float(np.median(a - b)) * r.dt for r, (a, b) in zip(ctx.records, pairs, strict=True)
             if len(a)]
    return float(np.median(spans)) if spans else math.nan


def untested_entry(ctx: FitContext, fit: Fit, rounds: Sequence[RoundRow],
                   settled: Sequence[str]) -> Untestable | None:
    """The report's entry for creep when it was tested only from cycle to cycle of a
    repeated input (no hold after an input change), found nothing, and could not have found
    a creep of :data:`PLAUSIBLE_CREEP` per decade (:func:`settling_limit` above it); ``None``
    otherwise.

    Parameters
    ----------
    ctx : FitContext
    fit : Fit
        The final model (its prediction is what the bank acts on, its residual what the
        changes are taken of).
    rounds : sequence of RoundRow
        The run's rounds: creep's last row is the test that found nothing.
    settled : sequence of str
        Effects that already speak of creep: named, left ambiguous with a name, suggested.
        Creep among them: no entry.
    """
    if CREEP in settled:
        return None
    rows = [r for r in rounds if r.effect == CREEP]
    sig = cycle_signature(ctx)
    if not rows or sig is None or sig.previous is None:
        return None
    pairs = _pairs(sig.previous)
    period = _period_s(ctx, pairs)
    taus = bank_taus(ctx)
    slow = tuple(t for t in taus if t >= period)
    fast = tuple(t for t in taus if t < period)
    limit = settling_limit(fit.pred, ctx.all_res(fit), pairs, slow,
                           [r.dt for r in ctx.records])
    if limit <= PLAUSIBLE_CREEP:
        return None
    cycles = round(sum(len(a) * r.dt for r, (a, _) in zip(ctx.records, pairs, strict=True))
                   / period)
    start = min(r.t[a[0]] - r.t[0] for r, (a, _) in zip(ctx.records, pairs, strict=True)
                if len(a))
    row = rows[-1]
    size = ("no creep could reach" if not math.isfinite(limit) else
            f"a creep below about {100 * limit:.2g} % of a step per decade (devices show "
            f"0.1-{100 * PLAUSIBLE_CREEP:.0f} %) would not reach")
    cyc = f"{cycles} cycle{'s' if cycles != 1 else ''} from {start:.3g} s"
    slowest = _seconds(min(slow)) if slow else "one period"
    parts = [
        f"there is no hold after an input change, so creep was tested only by the settling "
        f"of its lags of {slowest} and longer from one repeated input cycle to the next "
        f"({cyc}, each against the one before), where it found none (held-out MSE "
        f"{-100 * row.heldout_mse_reduction:+.1f} %, z = {row.dm_z:.2f}); {size} the "
        f"acceptance rule's {100 * RULE.min_gain:.0f} % there, against the recording's own "
        "change from cycle to cycle"]
    if fast:
        parts.append(f"its lags shorter than the {period:.3g} s period ("
                     f"{', '.join(_seconds(t) for t in fast)}) repeat with every cycle, like "
                     "loop width and a lag at one excitation rate")
    steps = [r.t[i] - r.t[0] for r in ctx.records for i in step_starts(r.u)]
    if 0 < len(steps) < RULE.min_events:
        at = ", ".join(f"{s:.3g} s" for s in steps)
        parts.append(f"the settling right after the input step{'s' if len(steps) > 1 else ''} "
                     f"at {at} is {_count(len(steps))}, fewer than "
                     f"the {RULE.min_events} independent events a name needs")
    return Untestable(CREEP, "; ".join(parts),
                      "an up-then-down staircase of input steps with holds of 3-30 s (>= 2 "
                      "decades of hold time): creep keeps moving the output in the direction "
                      "of the last step while the input rests",
                      {} if not math.isfinite(limit) else {"gamma_per_decade_below": limit})


def _count(n: int) -> str:
    """``n`` events in words: ``one event``, ``2 events``."""
    return "one event" if n == 1 else f"{n} events"


def _seconds(t: float) -> str:
    """A time constant in words: ``10 ms``, ``1 s``."""
    return f"{1000 * t:.3g} ms" if t < 1.0 else f"{t:.3g} s"
