"""The output's response after each input event: which output dynamics the rows after the
steps and reversals show, judged event by event with each event held out in turn.

A dead time, a first-order lag and a lightly damped mode after the hysteresis leave their
signature after the input's steps and reversals (notes §4.2): a dead time shows no response
for its length, a lag responds at once and smoothly, a mode rings at its frequency. A share
of the whole record's residual cannot see such a signature when it lives in the
milliseconds after one step. Here each kind is fitted to the base's prediction and judged
against the noise of the rows where the input rests before its first step
(:func:`rest_noise`, with its colour):

* everything is compared on first differences: what a stage changes within milliseconds
  of an event, and the noise; a base's loop misfit changes with the input over a cycle and
  hardly from one sample to the next, so it does not count for whichever stage shifts the
  prediction its way (notes §4.1);
* no window length is chosen: a stage changes the prediction ``d = G(y_hat) - y_hat`` only
  where it acts, and the score of an event, the reduction of its squared (differenced)
  error, takes its rows from ``d``; it is significant when it exceeds :data:`Z_ONE_SIDED`
  of its standard deviations under the rest rows' noise;
* a kind is *seen* after an event when its values, fitted on all the other events, make the
  event significantly better (leave-one-event-out); it is seen in *several independent
  events* when that holds for at least ``min_events``
  (:attr:`~core.diagnosis.acceptance.AcceptRule.min_events`) of them, otherwise the
  evidence is *suggestive* and the events it came from are said;
* each input step is also judged on its own rows (:class:`StepResponse`): the kind that
  predicts them best, and the kinds it does not beat significantly there (ambiguous). A
  mode damped too much to ring is no mode's signature.

The recording's own response (a measured actuator rings at its own frequency after a step)
is part of what the base misses: with one step it is seen after one event, which is never
enough for a name, whatever its frequency; and a stage added to such a recording is told by
its step relative to that response (its dead time adds to the recording's own).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._typing import Float1D
from ..recordings import Recording
from ..stages import Delay, Lag, Resonance
from .acceptance import RULE
from .effects.resonance import RINGING_MAX_DAMPING
from .events import QUIET_SHARE, STEP_SAMPLES, event_windows, step_starts

__all__ = [
    "COLOUR_SE",
    "KINDS",
    "MAX_STEP_DT_S",
    "MIN_REST_ROWS",
    "Z_ONE_SIDED",
    "EventResponse",
    "KindEvidence",
    "RestNoise",
    "StepResponse",
    "StepSuggestion",
    "event_response",
    "kind_prediction",
    "rest_noise",
]

#: The output dynamics kinds judged, in the order of notes §4.3.
KINDS = ("delay", "lag", "resonance")
#: The model algebra's stage of each kind (its values in the order of its fields).
_STAGES: dict[str, type[Delay | Lag | Resonance]] = {
    "delay": Delay, "lag": Lag, "resonance": Resonance,
}
#: One-sided 1 % normal quantile: an event counts for a kind (or a kind beats a look-alike
#: on it) when the reduction of its squared error is this many standard deviations above 0.
Z_ONE_SIDED = 2.326
#: Fewest rows with the input at rest before the first step for a noise floor from them.
MIN_REST_ROWS = 50
#: Longest sample interval the events are judged at, s: the dead times and time constants
#: searched span 50 ms after an event, which needs at least two samples.
MAX_STEP_DT_S = 0.025


#: Largest autocorrelation of the rest rows' first differences counted as noise-free (in
#: units of its standard error ``1 / sqrt(rows)``): the noise's colour is kept up to the last
#: lag above it (white noise exceeds it at a lag with probability 6e-5).
COLOUR_SE = 4.0


@dataclass(frozen=True)
class RestNoise:
    """The noise the statistics compare with: its first differences' autocovariance.

    Attributes
    ----------
    sigma : float
        Standard deviation of the noise (output units): that of its first differences over
        ``sqrt(2)``.
    acov : ndarray, shape (L + 1,)
        Autocovariance of the first differences at lags 0..L (output units squared),
        Bartlett-tapered; ``[2 sigma^2, -sigma^2]`` for white noise.
    """

    sigma: float
    acov: np.ndarray

    @classmethod
    def white(cls, sigma: float) -> RestNoise:
        """White noise of standard deviation ``sigma``."""
        return cls(float(sigma), np.array([2.0 * sigma**2, -(sigma**2)]))

    def var(self, w: np.ndarray) -> float:
        """Variance of ``sum(dn * w)`` for the noise's first differences ``dn``."""
        c = self.acov
        v = c[0] * float(w @ w)
        for k in range(1, min(c.size, w.size)):
            v += 2.0 * c[k] * float(w[:-k] @ w[k:])
        return max(v, 0.0)


def rest_noise(rec: Recording) -> RestNoise | None:
    """The noise of the rows before the first input step where the input rests (changes by
    at most :data:`~core.diagnosis.events.QUIET_SHARE` of its range): the autocovariance of
    the output's first differences there, up to the last lag whose autocorrelation exceeds
    :data:`COLOUR_SE` standard errors. ``None`` without a step or with fewer than
    :data:`MIN_REST_ROWS` rows at rest."""
    st = step_starts(rec.u)
    if st.size == 0 or int(st[0]) < MIN_REST_ROWS:
        return None
    u = np.asarray(rec.u[: int(st[0])], dtype=np.float64)
    still = np.abs(u - u[-1]) <= QUIET_SHARE * float(np.ptp(rec.u))
    rest = int(np.argmin(still[::-1])) if not still.all() else still.size
    if rest < MIN_REST_ROWS:
        return None
    dy = np.diff(np.asarray(rec.y, dtype=np.float64)[u.size - rest : u.size])
    dy = dy - dy.mean()
    n = dy.size
    c = np.array([float(dy[: n - k] @ dy[k:]) / n for k in range(n // 4)])
    if not c[0] > 0:
        return None
    above = np.flatnonzero(np.abs(c[1:] / c[0]) >= COLOUR_SE / np.sqrt(n))
    lags = int(above[-1]) + 2 if above.size else 2
    # Bartlett weights beyond lag 1 (keeps the variance >= 0); lag 1 whole: the differencing
    # itself puts -sigma^2 there for white noise
    taper = np.minimum(1.0, 1.0 - (np.arange(lags) - 1.0) / lags)
    return RestNoise(float(np.sqrt(c[0] / 2.0)), c[:lags] * taper)


def kind_prediction(kind: str, values: tuple[float, ...], yhat: Float1D, dt: float) -> np.ndarray:
    """``yhat`` through the output stage ``kind`` of the model algebra (:mod:`core.stages`:
    :class:`~core.stages.Delay`, :class:`~core.stages.Lag`, :class:`~core.stages.Resonance`,
    the filters discretised by first-order hold), at rest at ``yhat[0]``.

    Parameters
    ----------
    kind : {"delay", "lag", "resonance"}
    values : tuple of float
        ``(delay_s,)``, ``(tau_s,)`` or ``(freq_hz, damping)``.
    yhat : ndarray, shape (n,)
        The base's prediction (output units) on a uniform time axis.
    dt : float
        Sampling interval (s).

    Returns
    -------
    ndarray, shape (n,)
    """
    stage = _STAGES.get(kind)
    if stage is None:
        raise ValueError(f"unknown output dynamics kind {kind!r}; known: {', '.join(KINDS)}")
    y = np.asarray(yhat, dtype=np.float64)
    return np.asarray(stage(*values).simulate(y, dt=dt).y)


def _grid(kind: str, dt: float) -> list[tuple[float, ...]]:
    """Starting values of ``kind``: time constants from one sample to 50 ms, modes from
    50 Hz to 0.4 of the sampling rate (a factor 2^(1/4) apart), damping 0.02-0.3."""
    if kind == "delay":  # whole samples: a step's dead time has no slope to walk down
        return [(float(k * dt),) for k in range(1, max(1, int(round(0.05 / dt))) + 1)]
    if kind == "lag":
        return [(float(v),) for v in np.geomspace(dt, 0.05, 24)]
    fs = np.geomspace(50.0, 0.4 / dt, max(2, int(np.log(0.4 / dt / 50.0) / np.log(2**0.25)) + 1))
    return [(float(f), float(z)) for f in fs for z in (0.02, 0.08, 0.3)]


def _grid_errors(
    kind: str, yhat: np.ndarray, y: np.ndarray, masks: list[np.ndarray], dt: float
) -> tuple[list[tuple[float, ...]], np.ndarray]:
    """The grid of ``kind`` (:func:`_grid`) and, per grid point and event window, the sum of
    the squared first differences of the error there, shape (n_grid, n_windows)."""
    grid = _grid(kind, dt)
    pairs = [m[1:] & m[:-1] for m in masks]
    out = np.empty((len(grid), len(masks)))
    for i, v in enumerate(grid):
        e2 = np.diff(y - kind_prediction(kind, v, yhat, dt)) ** 2
        out[i] = [float(e2[p].sum()) for p in pairs]
    return grid, out


def _fit(
    kind: str,
    yhat: np.ndarray,
    y: np.ndarray,
    rows: np.ndarray,
    dt: float,
    start: tuple[float, ...] | None = None,
) -> tuple[float, ...]:
    """Values of ``kind`` minimising the squared first differences of the error on
    ``rows`` (:func:`_z`): Nelder-Mead in log coordinates from ``start`` (default: the
    best point of its grid)."""
    import scipy.optimize as so

    pairs = rows[1:] & rows[:-1]
    stop = int(np.flatnonzero(rows)[-1]) + 1 if rows.any() else 0
    yh, yy, pairs = yhat[:stop], y[:stop], pairs[: max(stop - 1, 0)]

    def sse(v: tuple[float, ...]) -> float:
        e = np.diff(yy - kind_prediction(kind, v, yh, dt))[pairs]
        return float(e @ e)

    best = min(_grid(kind, dt), key=sse) if start is None else start

    def obj(p: np.ndarray) -> float:
        v = tuple(float(x) for x in np.exp(p))
        if kind == "resonance" and not (20.0 <= v[0] <= 0.45 / dt and 0.005 <= v[1] <= 1.0):
            return math.inf
        if kind != "resonance" and not (0.1 * dt <= v[0] <= 0.2):
            return math.inf
        return sse(v)

    r = so.minimize(
        obj,
        np.log(best),
        method="Nelder-Mead",
        options={"maxfev": 40, "xatol": 0.01, "fatol": 1e-12},
    )
    return tuple(float(x) for x in np.exp(r.x)) if r.fun < sse(best) else best


def _z(e: np.ndarray, d: np.ndarray, noise: RestNoise) -> float:
    """Standardised reduction of the squared first differences of the error ``e`` by the
    change ``d`` (``e - d`` left): ``(|De|^2 - |D(e - d)|^2) / sd``, where ``sd`` is its
    standard deviation when ``e`` is the rest rows' noise (:class:`RestNoise`, with its
    colour); 0 where ``d`` does not change.

    The first difference leaves the fast part of both: what a stage changes within
    milliseconds of an event, and the noise. A base's misfit of the loop changes with the
    input, over a cycle, and hardly from one sample to the next; it would otherwise count
    as evidence for whichever stage shifts the prediction the same way (notes §4.1: at low
    frequency every linear stage is ``g1 dy/dt``, which a loop's width mimics)."""
    de, dd = np.diff(e), np.diff(d)
    v = noise.var(dd)
    if not v > 0.0:
        return 0.0
    return float((2.0 * (de @ dd) - dd @ dd) / (2.0 * np.sqrt(v)))


@dataclass(frozen=True)
class KindEvidence:
    """What one kind shows after the events, each held out in turn.

    Attributes
    ----------
    kind : str
    values : tuple of float
        Its values fitted on all the events (``(delay_s,)``, ``(tau_s,)`` or
        ``(freq_hz, damping)``).
    z : tuple of float
        Per event: the standardised reduction of the event's squared error by the kind,
        fitted without the event (:data:`Z_ONE_SIDED` and above: seen).
    seen : tuple of int
        Start rows of the events after which it is seen.
    """

    kind: str
    values: tuple[float, ...]
    z: tuple[float, ...]
    seen: tuple[int, ...]


@dataclass(frozen=True)
class StepResponse:
    """What the rows after one input step show, each kind fitted on them alone.

    Attributes
    ----------
    start : int
        Start row of the step.
    kind : str or None
        The kind that predicts the step's rows best (a mode only when it rings: damping
        below :data:`~core.diagnosis.effects.resonance.RINGING_MAX_DAMPING`), ``None``
        when it does not beat the base significantly.
    ambiguous_with : tuple of str
        Kinds that ``kind`` does not beat by :data:`Z_ONE_SIDED` on these rows (:func:`_z`;
        each kind fitted on the same rows, so an in-sample comparison, not a held-out one).
    values : dict of str to tuple of float
        Each kind's values fitted on the step's rows.
    """

    start: int
    kind: str | None
    ambiguous_with: tuple[str, ...]
    values: dict[str, tuple[float, ...]]


@dataclass(frozen=True)
class StepSuggestion:
    """An output dynamics kind every input step shows, on fewer steps than a name needs.

    Attributes
    ----------
    kind : str
        ``"delay"``, ``"lag"`` or ``"resonance"``.
    values : tuple of float
        Its values fitted on the steps' rows (the median over the steps): ``(delay_s,)``,
        ``(tau_s,)`` or ``(freq_hz, damping)``.
    steps_s : tuple of float
        Times of the input steps it was seen after (s from the record's first sample).
    ambiguous_with : tuple of str
        Kinds a step does not tell it apart from.
    min_events : int
        Fewest independent events a name needs.
    """

    kind: str
    values: tuple[float, ...]
    steps_s: tuple[float, ...]
    ambiguous_with: tuple[str, ...]
    min_events: int

    @property
    def parameters(self) -> dict[str, float]:
        """Its values by the stage's field names (``delay_s``, ``tau_s``, ``freq_hz``,
        ``damping``)."""
        names = [f.name for f in _STAGES[self.kind].fields]
        return dict(zip(names, self.values, strict=True))

    @property
    def text(self) -> str:
        """What was seen, where, and what experiment would decide, in words."""
        at = ", ".join(f"{t:.3g} s" for t in self.steps_s)
        amb = (
            f", not told apart from {' or '.join(_NAMES[k] for k in self.ambiguous_with)}"
            if self.ambiguous_with
            else ""
        )
        n = len(self.steps_s)
        return (
            f"{_WORDS[self.kind]} ({_values(self.kind, self.values)}) after the input "
            f"step{'s' if n > 1 else ''} at {at}{amb}: seen after {n} input "
            f"step{'s' if n > 1 else ''}, fewer than the {self.min_events} independent "
            "events a name needs; a recording with more input steps (each held out in "
            "turn) would decide"
        )


@dataclass(frozen=True)
class EventResponse:
    """The output dynamics the events of one recording show.

    Attributes
    ----------
    noise : float
        Noise floor (output units) the statistics use (:func:`rest_noise`, or the one given).
    events : tuple of int
        Start rows of the events judged (steps and large reversals).
    kinds : dict of str to KindEvidence
    best : str or None
        The kind seen after the most events held out (ties: the larger summed score),
        ``None`` when none is seen after any.
    ambiguous_with : tuple of str
        Kinds also seen that ``best`` does not beat, held out, after ``min_events`` of the
        events it is seen after (or all of them when fewer).
    several : bool
        ``best`` is seen after at least ``min_events`` independent events: evidence for a
        name. Otherwise what the events show is suggestive, however large.
    steps : tuple of StepResponse
        Each input step judged on its own rows.
    min_events : int
        Fewest independent events a name needs (the ``min_events`` judged with).
    """

    noise: float
    events: tuple[int, ...]
    kinds: dict[str, KindEvidence]
    best: str | None
    ambiguous_with: tuple[str, ...]
    several: bool
    steps: tuple[StepResponse, ...]
    min_events: int = RULE.min_events

    @property
    def step_kind(self) -> str | None:
        """The kind every input step shows, told apart from the other kinds on each step's
        own rows; ``None`` without steps, when a step shows none or when they disagree."""
        kinds = {st.kind for st in self.steps}
        if len(kinds) != 1 or None in kinds or any(st.ambiguous_with for st in self.steps):
            return None
        return next(iter(kinds))

    def step_suggestion(self, dt: float) -> StepSuggestion | None:
        """The kind every input step shows on its own rows, when the steps are fewer than
        ``min_events`` (so it is suggestive whatever its size); ``None`` without steps, with
        ``min_events`` or more of them, or when a step shows none or they disagree.

        Parameters
        ----------
        dt : float
            Sampling interval (s).
        """
        if not self.steps or len(self.steps) >= self.min_events:
            return None
        kinds = {st.kind for st in self.steps}
        if len(kinds) != 1 or None in kinds:
            return None
        kind = next(iter(kinds))
        assert kind is not None
        vals = np.median(np.array([st.values[kind] for st in self.steps]), axis=0)
        amb = tuple(k for k in KINDS if any(k in st.ambiguous_with for st in self.steps))
        return StepSuggestion(
            kind,
            tuple(float(v) for v in vals),
            tuple(st.start * dt for st in self.steps),
            amb,
            self.min_events,
        )

    def where(self, dt: float) -> str:
        """Where the evidence came from, in words (times in s): the kind seen after the
        most events held out in turn, and what each input step shows on its own rows."""
        starts = {s.start for s in self.steps}
        if self.best is not None and self.several:
            seen = self.kinds[self.best].seen
            at = ", ".join(
                f"{'the step' if s in starts else 'a reversal'} at {s * dt:.3g} s" for s in seen
            )
            amb = (
                f", not told apart from {' or '.join(_NAMES[k] for k in self.ambiguous_with)}"
                if self.ambiguous_with
                else ""
            )
            parts = [
                f"{_NAMES[self.best]} seen after {len(seen)} of {len(self.events)} input "
                f"events, each held out in turn ({at}){amb}"
            ]
        else:
            parts = [
                f"no output dynamics seen after {self.min_events} or more of the "
                f"{len(self.events)} input events, each held out in turn"
            ]
        for st in self.steps:
            if st.kind is None:
                parts.append(
                    f"the input step at {st.start * dt:.3g} s shows no output "
                    "dynamics beyond the model's"
                )
                continue
            amb = (
                f", not told apart from {' or '.join(_NAMES[k] for k in st.ambiguous_with)}"
                if st.ambiguous_with
                else ""
            )
            parts.append(
                f"the input step at {st.start * dt:.3g} s shows "
                f"{_WORDS[st.kind]} ({_values(st.kind, st.values[st.kind])}){amb}"
            )
        if self.steps and len(self.steps) < self.min_events:
            parts[-1] += (
                f"; the kind the steps show rests on fewer than {self.min_events} "
                "events, suggestive (more steps would decide)"
            )
        return "; ".join(parts)


_NAMES = {"delay": "a dead time", "lag": "a lag", "resonance": "a mode"}
_WORDS = {
    "delay": "a dead time (no response for its length)",
    "lag": "a lag (an immediate, smooth response)",
    "resonance": "a mode (ringing at its frequency)",
}


def _values(kind: str, v: tuple[float, ...]) -> str:
    if kind == "resonance":
        return f"{v[0]:.4g} Hz, damping {v[1]:.2g}"
    return f"{1e3 * v[0]:.3g} ms"


def _rings(kind: str, v: tuple[float, ...]) -> bool:
    """``False`` for a mode damped too much to ring
    (:data:`~core.diagnosis.effects.resonance.RINGING_MAX_DAMPING`), else ``True``."""
    return kind != "resonance" or v[1] < RINGING_MAX_DAMPING


def _beaten(
    y: np.ndarray, preds: dict[str, np.ndarray], best: str, m: np.ndarray, noise: RestNoise
) -> dict[str, bool]:
    """Whether ``best`` predicts rows ``m`` significantly better than each other kind."""
    return {
        k: _z(y[m] - p[m], preds[best][m] - p[m], noise) >= Z_ONE_SIDED
        for k, p in preds.items()
        if k != best
    }


def _step(
    rec: Recording, yh: np.ndarray, m: np.ndarray, start: int, noise: RestNoise, dt: float
) -> StepResponse:
    """Each kind fitted on the rows ``m`` of one step and compared there."""
    y = np.asarray(rec.y, dtype=np.float64)
    vals = {k: _fit(k, yh, y, m, dt) for k in KINDS}
    preds = {k: kind_prediction(k, v, yh, dt) for k, v in vals.items()}
    e = np.diff((y - yh)[m])
    gain = {
        k: float(e @ e) - float(np.sum((e - np.diff((p - yh)[m])) ** 2)) for k, p in preds.items()
    }
    # a mode damped too much to ring shows no ringing: it is no mode's signature
    best = max((k for k in KINDS if _rings(k, vals[k])), key=lambda k: gain[k])
    if _z((y - yh)[m], (preds[best] - yh)[m], noise) < Z_ONE_SIDED:
        return StepResponse(start, None, (), vals)
    beaten = _beaten(y, preds, best, m, noise)
    return StepResponse(start, best, tuple(k for k, b in beaten.items() if not b), vals)


def event_response(
    rec: Recording, yhat: Float1D, noise: float | None = None, min_events: int = RULE.min_events
) -> EventResponse | None:
    """Which output dynamics the events of ``rec`` show on top of the base prediction.

    Parameters
    ----------
    rec : Recording
        One recording with a uniform time axis.
    yhat : ndarray, shape (n_samples,)
        The base's prediction of ``rec.y`` (without output dynamics).
    noise : float, optional
        Noise floor (output units) when the recording has no rest before a step
        (:func:`rest_noise` first).
    min_events : int
        Events needed for evidence from several independent events.

    Returns
    -------
    EventResponse or None
        ``None`` with fewer than two events or no noise floor.
    """
    rest = rest_noise(rec)
    if rest is None and noise is not None and noise > 0:
        rest = RestNoise.white(noise)
    wins = event_windows(rec)
    if rest is None or len(wins) < 2:
        return None
    dt = float(rec.t[1] - rec.t[0])
    y = np.asarray(rec.y, dtype=np.float64)
    yh = np.asarray(yhat, dtype=np.float64)
    n = y.size
    e0 = y - yh
    masks = []
    for a, b in wins:
        m = np.zeros(n, dtype=bool)
        m[a:b] = True
        masks.append(m)
    every = np.logical_or.reduce(masks)
    kinds: dict[str, KindEvidence] = {}
    held: dict[str, list[np.ndarray]] = {}
    for kind in KINDS:
        grid, errs = _grid_errors(kind, yh, y, masks, dt)
        total = errs.sum(axis=1)
        vals = [
            _fit(kind, yh, y, every & ~m, dt, grid[int(np.argmin(total - errs[:, i]))])
            for i, m in enumerate(masks)
        ]
        preds = [kind_prediction(kind, v, yh, dt) for v in vals]
        # a mode damped too much to ring is no mode's signature (it only delays)
        zs = [
            _z(e0[m], (p - yh)[m], rest) if _rings(kind, v) else 0.0
            for p, m, v in zip(preds, masks, vals, strict=True)
        ]
        held[kind] = preds
        seen = tuple(a for (a, _), z in zip(wins, zs, strict=True) if z >= Z_ONE_SIDED)
        kinds[kind] = KindEvidence(
            kind, _fit(kind, yh, y, every, dt, grid[int(np.argmin(total))]), tuple(zs), seen
        )
    st = set(int(s) for s in step_starts(rec.u))
    steps = tuple(
        _step(rec, yh, m, a, rest, dt)
        for (a, _), m in zip(wins, masks, strict=True)
        if any(abs(a - s) < STEP_SAMPLES for s in st)
    )
    starts = tuple(a for a, _ in wins)
    counts = {k: len(ev.seen) for k, ev in kinds.items()}
    best = max(KINDS, key=lambda k: (counts[k], sum(max(z, 0.0) for z in kinds[k].z)))
    if counts[best] == 0:
        return EventResponse(rest.sigma, starts, kinds, None, (), False, steps, min_events)
    amb = []
    for other in KINDS:
        if other == best or counts[other] == 0:
            continue
        beats = sum(
            _beaten(y, {best: held[best][i], other: held[other][i]}, best, m, rest)[other]
            for i, m in enumerate(masks)
            if wins[i][0] in kinds[best].seen
        )
        if beats < min(min_events, counts[best]):
            amb.append(other)
    return EventResponse(
        rest.sigma, starts, kinds, best, tuple(amb), counts[best] >= min_events, steps,
        min_events,
    )
