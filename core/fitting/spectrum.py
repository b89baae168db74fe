"""The periodogram every residual-spectrum reader of the project uses (one routine)."""

from __future__ import annotations

import numpy as np

from .._typing import Float1D

__all__ = ["periodogram"]


def periodogram(e: Float1D, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies (Hz) and periodogram of ``e`` (mean removed, a Hann taper): the finest
    spectrum the record gives, ``1 / T`` apart.

    The taper keeps a line's power within two bins of it (its sidelobes fall 18 dB an
    octave), so a strong harmonic does not leak into the bins a fit or a peak search reads.

    Parameters
    ----------
    e : ndarray of shape (N,)
        Evenly sampled signal.
    dt : float
        Sample spacing (s).

    Returns
    -------
    f : ndarray of shape (N // 2 + 1,)
        Frequencies, Hz.
    power : ndarray of shape (N // 2 + 1,)
        ``|FFT|^2`` of the tapered signal over the taper's energy (units of ``e`` squared).
    """
    x = np.asarray(e, dtype=np.float64)
    w = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(x.size) / max(x.size, 1))  # periodic Hann
    spec = np.abs(np.fft.rfft((x - x.mean()) * w)) ** 2 / (float(np.sum(w * w)) or 1.0)
    return np.fft.rfftfreq(x.size, dt), spec
