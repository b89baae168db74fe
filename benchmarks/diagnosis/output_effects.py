"""Known effects applied to a recorded output: the concealed effects of the sealed set.

The development set builds its hidden effects from the core's own models (``core.stages``:
``Delay``, ``Lag``, ``Resonance``, ``Creep``, ``Drift``). The sealed set must not share code
with the thing it tests, so its effects are written here a second time, directly in
numpy/scipy, as operations on a sampled output ``y`` (shape ``(n,)``, sampling step ``dt`` in
s). Every linear effect acts on the deviation from the first sample (the device is at rest
when the recording starts): ``y' = y[0] + F(y - y[0])``, so the unmodified start of a
recording stays where it was.

``dead_time``
    ``y'[k] = y[k - m]`` for an integer number of samples ``m`` (the first value is held
    for the first ``m`` samples): exactly ``m dt`` of no response.
``first_order_lag``
    ``tau y' + y' = y`` discretised by the step-invariant pole ``a = exp(-dt / tau)``:
    ``y'[k] = a y'[k-1] + (1 - a) y[k]`` (unit gain at DC, responds at once and smoothly).
``mode``
    ``w_n^2 / (s^2 + 2 zeta w_n s + w_n^2)`` by the bilinear transform prewarped at
    ``freq_hz`` (the discrete resonance sits exactly at ``freq_hz``; unit gain at DC).
``creep``
    a bank of first-order lags, ``y' = y + sum_j c_j (L_tau_j[y] - y)``: after a step the
    output keeps moving in the direction of the step by about ``c_j`` per lag.
``linear_drift``
    ``y' = y + a (t - t[0]) / (t[-1] - t[0])``: a ramp from 0 to ``a`` over the record.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.signal as ss

__all__ = ["apply_effect", "creep", "dead_time", "first_order_lag", "linear_drift", "mode",
           "mode_filter"]


def _rest(y: np.ndarray) -> tuple[np.ndarray, float]:
    y = np.asarray(y, dtype=np.float64)
    if y.ndim != 1 or y.size < 2:
        raise ValueError(f"the output must be a 1-D array of at least 2 samples, got shape "
                         f"{y.shape}")
    return y - y[0], float(y[0])


def dead_time(y: np.ndarray, samples: int) -> np.ndarray:
    """``y`` delayed by ``samples`` (an integer >= 0); the first value is held meanwhile."""
    if int(samples) != samples or samples < 0:
        raise ValueError(f"a dead time is a whole number of samples >= 0, got {samples!r}")
    y = np.asarray(y, dtype=np.float64)
    m = int(samples)
    if m == 0:
        return y.copy()
    out = np.empty_like(y)
    out[:m] = y[0]
    out[m:] = y[:-m]
    return out


def _lag(x: np.ndarray, tau_s: float, dt: float) -> np.ndarray:
    a = math.exp(-dt / tau_s)
    return ss.lfilter([1.0 - a], [1.0, -a], x)


def first_order_lag(y: np.ndarray, tau_s: float, dt: float) -> np.ndarray:
    """``y`` through a unit-gain first-order lag of time constant ``tau_s`` (s), at rest."""
    if not tau_s > 0 or not dt > 0:
        raise ValueError(f"tau_s and dt must be > 0 (s), got {tau_s!r} and {dt!r}")
    d, y0 = _rest(y)
    return y0 + _lag(d, tau_s, dt)


def mode_filter(freq_hz: float, damping: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(b, a)`` of the discrete unit-gain second-order mode (bilinear, prewarped)."""
    if not 0 < freq_hz < 0.5 / dt:
        raise ValueError(f"the mode frequency must lie between 0 and the Nyquist frequency "
                         f"{0.5 / dt:g} Hz, got {freq_hz!r}")
    if not 0 < damping < 1:
        raise ValueError(f"the damping ratio must lie in (0, 1), got {damping!r}")
    fs = 1.0 / dt
    wn = 2 * fs * math.tan(math.pi * freq_hz / fs)  # prewarped: the peak maps to freq_hz
    b, a = ss.bilinear([wn * wn], [1.0, 2 * damping * wn, wn * wn], fs)
    return np.asarray(b), np.asarray(a)


def mode(y: np.ndarray, freq_hz: float, damping: float, dt: float) -> np.ndarray:
    """``y`` through a lightly damped second-order mode (unit gain at DC), at rest."""
    d, y0 = _rest(y)
    b, a = mode_filter(freq_hz, damping, dt)
    return y0 + ss.lfilter(b, a, d)


def creep(y: np.ndarray, taus_s: Sequence[float], weights: Sequence[float],
          dt: float) -> np.ndarray:
    """``y`` through a creep lag bank (``weights``: fraction of a step per lag), at rest."""
    if len(taus_s) != len(weights) or not all(t > 0 for t in taus_s):
        raise ValueError("creep needs one positive time constant (s) per weight")
    d, y0 = _rest(y)
    out = d.copy()
    for tau, c in zip(taus_s, weights, strict=True):
        out += c * (_lag(d, tau, dt) - d)
    return y0 + out


def linear_drift(t: np.ndarray, y: np.ndarray, amount: float) -> np.ndarray:
    """``y`` plus a ramp from 0 at ``t[0]`` to ``amount`` (output units) at ``t[-1]``."""
    t = np.asarray(t, dtype=np.float64)
    span = float(t[-1] - t[0])
    if not span > 0:
        raise ValueError("a drift needs a time axis that increases")
    return np.asarray(y, dtype=np.float64) + amount * (t - t[0]) / span


def apply_effect(effect: str, t: np.ndarray, y: np.ndarray, params: dict) -> np.ndarray:
    """Apply one named effect with its truth ``params`` to the output ``y`` at times ``t``.

    ``delay``: ``samples``; ``lag``: ``tau_s``; ``resonance``: ``freq_hz``, ``damping``;
    ``creep``: ``taus_s``, ``weights``; ``drift``: ``amount`` (output units over the record).
    """
    dt = float(t[1] - t[0])
    if effect == "delay":
        return dead_time(y, params["samples"])
    if effect == "lag":
        return first_order_lag(y, params["tau_s"], dt)
    if effect == "resonance":
        return mode(y, params["freq_hz"], params["damping"], dt)
    if effect == "creep":
        return creep(y, params["taus_s"], params["weights"], dt)
    if effect == "drift":
        return linear_drift(t, y, params["amount"])
    raise ValueError(f"unknown effect {effect!r}; known: delay, lag, resonance, creep, drift")
