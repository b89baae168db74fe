"""Recordings in periodic steady state, and the warm-up input that starts a model there.

A recording whose input is one cycle repeated (its output already periodic), or a single
closed loop (one cycle whose input and output return to where they started, as a measured
B-H loop that starts at its peak field), did not start from the relaxed memory: its memory
at the first sample is the one its own cycle leaves. Both commands start their models from
it: ``hyst diagnose``'s baseline (:mod:`core.diagnosis.basechoice`) runs the cycle's two
extremes as a virtual input history before the first sample, and ``hyst fit``
(:func:`core.fitting.fit_recordings`) runs the :func:`warm_up` input made of the same
extremes. The detection (:func:`steady_state_history`) is shared by both.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._typing import Float1D
from ..recordings import Recording
from .thresholds import reversal_indices, wipeout_index

__all__ = ["CLOSED_TOL", "STEADY_TOL", "WARM_UP_SAMPLES", "SteadyStart", "closed_loop_history",
           "steady_state_history", "warm_up"]

#: Allowance (fraction of the output range) on top of 1.5x the period-to-period RMS
#: difference of the later periods, within which the first period counts as steady state.
STEADY_TOL = 0.002

#: A single cycle is a closed loop when its last sample is within this fraction of the input
#: range and of the output range of its first sample.
CLOSED_TOL = 0.02


def steady_state_history(rec: Recording) -> tuple[float, ...]:
    """Virtual input history that puts the memory in the recording's periodic steady state.

    Returns ``(first, second)``: the cycle's two extremes in the order the input last visits
    them before one period has elapsed; empty when the input is not one cycle repeated (at
    least three periods, ``u(t + T)`` within 2 % of the input range of ``u(t)`` over the
    whole record) or when the output of the first period differs from the second's by more
    than 1.5 times the second's difference from the third plus :data:`STEADY_TOL` of the
    output range, on the rows before the wipe-out time (a virgin start, or a transient).
    """
    u, y = rec.u, rec.y
    span = float(np.ptp(u))
    if span <= 0:
        return ()
    rv = reversal_indices(u, 0.1 * span)
    rv = rv[(rv > 0) & (rv < u.size - 1)]
    if rv.size < 4:
        return closed_loop_history(rec)
    period = int(rv[2] - rv[0])
    if period < 4 or 3 * period > u.size:
        return closed_loop_history(rec)
    ext = u[rv]
    if np.ptp(ext[::2]) > 0.02 * span or np.ptp(ext[1::2]) > 0.02 * span:
        return ()
    # the whole record is the one cycle repeated (not a sweep, not a decaying sine)
    if np.sqrt(np.mean((u[:-period] - u[period:]) ** 2)) > 0.02 * span:
        return ()
    # the first period's output repeats as well as the later periods repeat each other
    # (noise), plus STEADY_TOL of the output range
    yr = float(np.ptp(y)) or 1.0
    # (on the rows before the wipe-out time: the only rows an initial memory changes)
    w = max(min(wipeout_index(u), period), 2)
    d12 = float(np.sqrt(np.mean((y[:w] - y[period : period + w]) ** 2)))
    d23 = float(np.sqrt(np.mean((y[period : period + w] - y[2 * period : 2 * period + w]) ** 2)))
    if d12 > 1.5 * d23 + STEADY_TOL * yr:
        return ()
    seg = u[1 : period + 1]
    i_hi, i_lo = int(np.argmax(seg)), int(np.argmin(seg))
    hi, lo = float(seg[i_hi]), float(seg[i_lo])
    return (hi, lo) if i_hi < i_lo else (lo, hi)


def closed_loop_history(rec: Recording) -> tuple[float, ...]:
    """Virtual input history of a single closed loop (e.g. one measured B-H loop).

    The recording is one cycle: at most two large input reversals (> 10 % of the input
    range) inside it, and its last sample within :data:`CLOSED_TOL` of the input range and
    of the output range of its first sample. A closed loop is its own steady state: the
    memory at its first sample is the one the cycle leaves at its last. Returns the cycle's
    two extremes in the order the input visits them (empty when it is not a closed loop).
    """
    u, y = rec.u, rec.y
    span, yr = float(np.ptp(u)), float(np.ptp(y))
    if span <= 0 or u.size < 8:
        return ()
    rv = reversal_indices(u, 0.1 * span)
    rv = rv[(rv > 0) & (rv < u.size - 1)]
    if not 1 <= rv.size <= 2:
        return ()
    if abs(u[-1] - u[0]) > CLOSED_TOL * span or abs(y[-1] - y[0]) > CLOSED_TOL * yr:
        return ()
    seg = u[1:]
    i_hi, i_lo = int(np.argmax(seg)), int(np.argmin(seg))
    if float(seg[i_hi] - seg[i_lo]) < 0.9 * span:
        return ()
    hi, lo = float(seg[i_hi]), float(seg[i_lo])
    return (hi, lo) if i_hi < i_lo else (lo, hi)


#: Samples of each leg of the warm-up input (:func:`warm_up`): a ramp, so that a kind
#: integrated sample by sample (Bouc-Wen) follows it as it follows a measured branch; the
#: play-based kinds reach the same state with any number.
WARM_UP_SAMPLES = 64


def warm_up(history: tuple[float, ...], first: float,
            n: int = WARM_UP_SAMPLES) -> Float1D:
    """The input run before a recording in periodic steady state, so that the model starts
    from the memory the recording's own cycle leaves.

    The model starts relaxed at input 0 (as ``hyst diagnose``'s play operators start before
    their virtual history), or, where the cycle does not reach 0 (a unipolar drive), at the
    cycle's input nearest 0, so that the warm-up never travels further than the cycle does
    (the estimators place their thresholds on the travels of the input they are fitted on,
    warm-up included: a ramp from 0 to a cycle at 10-150 V would widen them past every
    travel of the recording). It follows a straight ramp of ``n`` samples to each extreme of
    ``history`` in turn and then towards ``first``, stopping one step short of it (the
    recording's first sample follows). The operators narrower than half the cycle's input
    range end in the state the cycle leaves whatever came before; the wider ones, which the
    cycle never moves across, keep what the ramp from the start left them.

    Parameters
    ----------
    history : tuple of float
        The cycle's extremes in the order the input last visits them
        (:func:`steady_state_history`), input units; empty: no warm-up.
    first : float
        The recording's first input sample (input units).
    n : int
        Samples per leg.

    Returns
    -------
    ndarray of shape (m,)
        The warm-up input, starting at 0 or the cycle's input nearest 0
        (``m = n * (len(history) + 1)``; 0 when ``history`` is empty).
    """
    if not history:
        return np.zeros(0)
    start = float(np.clip(0.0, min(history), max(history)))
    points = [start, *map(float, history), float(first)]
    legs = [np.linspace(a, b, n, endpoint=False) for a, b in zip(points[:-1], points[1:],
                                                               strict=True)]
    return np.concatenate(legs)


@dataclass(frozen=True, eq=False)
class SteadyStart:
    """How each recording of a fit starts: from the relaxed memory at its first sample, or,
    in periodic steady state, from the memory its own cycle leaves (after its warm-up).

    Attributes
    ----------
    history : tuple of tuple of float
        Per recording, the cycle's extremes (:func:`steady_state_history`; empty: the
        recording starts relaxed at its first sample).
    warm : tuple of ndarray
        Per recording, the warm-up input run before it (:func:`warm_up`; shape ``(m_k,)``,
        ``m_k = 0`` without one); empty when no recording is in steady state.
    """

    history: tuple[tuple[float, ...], ...]
    warm: tuple[Float1D, ...]

    @classmethod
    def of(cls, recs: Sequence[Recording]) -> SteadyStart:
        """The start of each of ``recs`` (detected as ``hyst diagnose`` detects it)."""
        hist = tuple(steady_state_history(r) for r in recs)
        if not any(hist):
            return cls(hist, ())
        return cls(hist, tuple(warm_up(h, float(r.u[0])) for h, r in zip(hist, recs,
                                                                            strict=True)))

    def rows(self, recs: Sequence[Recording], train: list[np.ndarray],
             test: list[np.ndarray]) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """The training and held-out rows of ``recs`` (given masks, or the fit's default
        split: the last 20 % of every recording held out), as masks per recording."""
        from ._data import prepare

        us, ys = [r.u for r in recs], [r.y for r in recs]
        multi = len(recs) > 1
        prep = prepare(us if multi else us[0], ys if multi else ys[0],
                       (train if multi else train[0]) if train else None,
                       (test if multi else test[0]) if test else None,
                       validation=0.2, min_train=1)
        return list(prep.train_masks), list(prep.test_masks)

    def pad_masks(self, masks: list[np.ndarray]) -> list[np.ndarray]:
        """``masks`` with the warm-up rows (false: neither fitted nor scored) put before."""
        if not self.warm or not masks:
            return masks
        return [np.concatenate((np.zeros(w.size, dtype=bool), m))
                for w, m in zip(self.warm, masks, strict=True)]

    def padded(self, recs: Sequence[Recording]) -> list[Recording]:
        """The recordings the model is fitted on: each with its warm-up before its first
        sample (the output there repeats the first sample's and is never used; the time
        axis steps back at its first step)."""
        if not self.warm:
            return list(recs)
        out = []
        for r, w in zip(recs, self.warm, strict=True):
            if not w.size:
                out.append(r)
                continue
            dt = float(r.t[1] - r.t[0]) if r.n_samples > 1 else 1.0
            t = np.concatenate((r.t[0] - dt * np.arange(w.size, 0, -1), r.t))
            out.append(dataclasses.replace(
                r, t=t, u=np.concatenate((w, r.u)),
                y=np.concatenate((np.full(w.size, float(r.y[0])), r.y)), extra={},
                extra_units={}, lines=None))
        return out

    def predict(self, run: Callable[[np.ndarray], Any], recs: Sequence[Recording]
                ) -> list[np.ndarray]:
        """The output of ``run`` (a fitted estimator's ``predict``, or a saved model called
        on an input) on each of ``recs``, each started as it was fitted (its warm-up run
        first, its output there dropped)."""
        warm = self.warm or tuple(np.zeros(0) for _ in recs)
        return [np.asarray(run(np.concatenate((w, r.u))))[w.size:]
                for w, r in zip(warm, recs, strict=True)]

    def note(self, recs: Sequence[Recording], memory: Any) -> dict[str, Any]:
        """The fit report's ``initial_memory`` entry: what the estimator did (``memory``,
        its own note, when it reports one) with the steady-state start in words and per
        recording (``steady_state``: the cycle's extremes, ``warm_up_samples``)."""
        note = dict(memory) if isinstance(memory, dict) else {}
        steady = [r.name for r, h in zip(recs, self.history, strict=True) if h]
        unit = f" {recs[0].units.get('input')}" if recs[0].units.get("input") else ""
        hist = "; ".join(f"{r.name}: {' -> '.join(f'{x:.4g}' for x in h)}{unit}"
                         for r, h in zip(recs, self.history, strict=True) if h)
        which = ("every recording is" if len(steady) == len(recs)
                 else f"{', '.join(steady)} {'is' if len(steady) == 1 else 'are'}")
        text = (f"initial memory: {which} in periodic steady state (a closed loop, or one "
                "input cycle repeated with its output already repeating), so the model starts "
                "from the memory its own cycle leaves, as hyst diagnose starts it: relaxed at "
                "input 0 (or at the cycle's input nearest 0 where the cycle does not reach it), "
                "then run through the cycle's two extremes to the first sample "
                f"({hist}; ramps of {WARM_UP_SAMPLES} samples, neither fitted nor scored). "
                "Replay a recording with the saved model the same way: that start, the "
                "extremes, then the recording")
        if len(steady) == len(recs):
            text += ". Every row is used for the weights (no unknown initial memory)"
        elif "summary" in note:
            text += (". The other recordings start relaxed at their first sample "
                     f"({note['summary']})")
        if isinstance(note.get("wipeout_index"), list):
            # the estimator counted the warm-up rows: in the recordings' own numbering
            note["wipeout_index"] = [max(int(tw) - int(w.size), 0) for tw, w in zip(
                note["wipeout_index"], self.warm, strict=True)]
        note.update(summary=text, steady_state=[list(h) for h in self.history],
                    warm_up_samples=[int(w.size) for w in self.warm])
        return note
