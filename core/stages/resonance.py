"""The second-order resonance ``ÿ + 2ζω_n ẏ + ω_n² y = ω_n² x`` and its inverse (the mode
cancelled, a third-order roll-off at ``bandwidth_hz``)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..base import Control, Field, register_model
from ..validation import as_finite_scalar
from .linear import (
    LinearStage,
)


@register_model
@dataclass(frozen=True, eq=False)
class Resonance(LinearStage):
    """Second-order mode after the hysteresis, ``G(s) = ω_n² / (s² + 2ζω_n s + ω_n²)``.

    Parameters
    ----------
    freq_hz : float
        Natural frequency ``f_n = ω_n / 2π`` in hertz, ``> 0``.
    damping : float
        Damping ratio ``ζ > 0`` (dimensionless).
    """

    type_name: ClassVar[str] = "resonance"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("freq_hz", "number", doc="natural frequency (Hz)", title="Natural frequency f_n",
              control=Control("f_n", "Hz", (0.01, 2.0), lower=0.0, strict=True, scale=100.0,
                              log=True)),
        Field("damping", "number", doc="damping ratio", title="Damping ratio ζ",
              control=Control("ζ", "1", (0.0, 1.5), step=0.001, relative=False, lower=0.0,
                              strict=True)),
    )
    freq_hz: float
    damping: float

    def __post_init__(self) -> None:
        f = as_finite_scalar(self.freq_hz, "freq_hz", positive=True)
        z = as_finite_scalar(self.damping, "damping", positive=True)
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "damping", z)

    def _tf(self) -> tuple[list[float], list[float]]:
        w = 2.0 * np.pi * self.freq_hz
        return [w * w], [1.0, 2.0 * self.damping * w, w * w]

    def time_constants(self) -> tuple[tuple[str, float], ...]:
        """The mode's ``1 / (2 pi f_n)`` (s)."""
        return (("resonance 1/(2 pi freq_hz)", 1.0 / (2 * math.pi * float(self.freq_hz))),)

    def inverse(self, bandwidth_hz: float | None = None) -> ResonanceInverse:
        """Inverse with a third-order roll-off at ``bandwidth_hz`` (default ``4 f_n``).

        The discretised mode has a sampling zero outside the unit disc (relative degree 2),
        so no stable exact inverse exists; see :class:`ResonanceInverse` for the error bound.
        """
        return ResonanceInverse(
            self.freq_hz, self.damping,
            4.0 * self.freq_hz if bandwidth_hz is None else bandwidth_hz,
        )


@register_model
@dataclass(frozen=True, eq=False)
class ResonanceInverse(LinearStage):
    """Inverse of a :class:`Resonance` with a documented roll-off.

    ``F(s) = G(s)⁻¹ L(s)`` with ``G`` the mode and the roll-off
    ``L(s) = (1 + 3s/ω_c) / (1 + s/ω_c)³`` (``ω_c = 2π f_c``), so ``G F = L``: the mode is
    cancelled and what is left is ``L``, whose error ``1 - L`` is of second order (no lag to
    first order). Error bound (continuous time): for any desired trajectory ``y_d`` with
    bounded curvature, ``|G F y_d - y_d| ≤ 3 max|ÿ_d| / ω_c²`` (``(1 - L)/s²`` has a positive
    impulse response of area ``3/ω_c²``); a sinusoid of frequency ``f`` comes back with a
    relative error ``≤ 3 (f/f_c)²``, against ``≈ (f/f_n)²`` without compensation. Sampling
    (FOH at ``dt``) adds an error of order ``(f_c dt)²`` (within 5 % of the bound for
    ``f_c dt ≤ 0.025``, about 60 % of it at ``f_c dt = 0.1``; tested). The
    high-frequency gain of ``F`` is ``3 (f_c/f_n)²``: a larger ``f_c`` tracks better and
    amplifies noise more.

    Parameters
    ----------
    freq_hz, damping : float
        The mode being inverted (Hz, dimensionless).
    bandwidth_hz : float
        Roll-off frequency ``f_c > 0`` in hertz.
    """

    type_name: ClassVar[str] = "resonance-inverse"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("freq_hz", "number", doc="natural frequency of the inverted mode (Hz)",
              title="Natural frequency f_n", scale_with=("bandwidth_hz",),
              control=Control("f_n", "Hz", (0.01, 1.5), lower=0.0, strict=True, scale=100.0,
                              log=True)),
        Field("damping", "number", doc="damping ratio of the inverted mode",
              title="Damping ratio ζ",
              control=Control("ζ", "1", (0.0, 1.5), step=0.001, relative=False, lower=0.0,
                              strict=True)),
        Field("bandwidth_hz", "number", doc="roll-off (triple pole) frequency (Hz)",
              title="Roll-off frequency", scale_with=("freq_hz",),
              control=Control("f_roll", "Hz", (0.01, 1.5), lower=0.0, strict=True,
                              scale=100.0, log=True)),
    )
    freq_hz: float
    damping: float
    bandwidth_hz: float

    def __post_init__(self) -> None:
        Resonance(self.freq_hz, self.damping)  # same rules
        object.__setattr__(self, "freq_hz", float(self.freq_hz))
        object.__setattr__(self, "damping", float(self.damping))
        object.__setattr__(
            self, "bandwidth_hz", as_finite_scalar(self.bandwidth_hz, "bandwidth_hz", positive=True)
        )

    def _tf(self) -> tuple[list[float], list[float]]:
        w = 2.0 * np.pi * self.freq_hz
        wc = 2.0 * np.pi * self.bandwidth_hz
        num = (wc * wc / (w * w)) * np.polymul([1.0, 2.0 * self.damping * w, w * w], [3.0, wc])
        return num.tolist(), [1.0, 3.0 * wc, 3.0 * wc * wc, wc**3]

    def rolloff(self) -> tuple[list[float], list[float]]:
        """``(num, den)`` of what remains after the mode, ``L(s)`` (highest power first)."""
        wc = 2.0 * np.pi * self.bandwidth_hz
        return [3.0 * wc * wc, wc**3], [1.0, 3.0 * wc, 3.0 * wc * wc, wc**3]

    def error_bound(self, max_curvature: float) -> float:
        """Bound on ``|G F y_d - y_d|`` for a trajectory with ``|ÿ_d| ≤ max_curvature``."""
        wc = 2.0 * np.pi * self.bandwidth_hz
        return 3.0 * abs(float(max_curvature)) / (wc * wc)

    def inverse(self) -> Resonance:
        """The mode itself (the roll-off is dropped: this is not an exact inverse)."""
        return Resonance(self.freq_hz, self.damping)
