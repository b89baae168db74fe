"""The dead time ``y(t) = x(t - τ_d)`` (fractional: interpolated) and its non-causal inverse,
the advance."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._typing import Float1D
from ..base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from ..exceptions import ParameterError
from ..validation import as_finite_scalar, filled


def delay_split(delay_s: float, dt: float) -> tuple[int, float]:
    """``(m, f)``: the delay in samples ``m + f`` with ``0 <= f < 1``."""
    D = delay_s / dt
    m = int(np.floor(D + 1e-12))
    return m, max(D - m, 0.0)


def _delay_field(doc: str) -> Field:
    return Field("delay_s", "number", doc=doc, title="Delay τ_d",
                 control=Control("τ_d", "s", (0.0, 2.0), lower=0.0, scale=1e-3))


@dataclass(frozen=True, eq=False)
class _Shift(Model):
    """What a delay and its inverse, the advance, share: the delay ``delay_s >= 0`` (s), no
    state of their own by default, the cost of one pass with a buffer of the delay."""

    needs_dt: ClassVar[bool] = True
    delay_s: float

    def __post_init__(self) -> None:
        d = as_finite_scalar(self.delay_s, "delay_s")
        if d < 0:
            raise ParameterError(
                f"delay_s = {d:g} must be >= 0 (a delay cannot predict the future)"
            )
        object.__setattr__(self, "delay_s", d)

    def default_state(self) -> Any:
        return None

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """One pass over the input plus a buffer of ``delay_s / dt`` samples (work in
        element operations, memory in bytes)."""
        m = self.delay_s / dt if dt and dt > 0 else 0.0
        n = float(samples) + m + 1.0
        return RunCost(4.0 * n, 6.0 * SAMPLE_BYTES * n)


@register_model
@dataclass(frozen=True, eq=False)
class Delay(_Shift):
    """Pure transport delay ``y(t) = x(t - τ_d)`` (DAQ latency, ZOH, digital filters).

    Fractional delays interpolate linearly between samples. The state is the buffer of the
    last ``floor(τ_d/dt) + 1`` inputs (oldest first); by default the buffer holds the first
    input sample (the signal was at rest before the record).

    Parameters
    ----------
    delay_s : float
        Delay in seconds, ``delay_s >= 0``.
    """

    type_name: ClassVar[str] = "delay"
    fields: ClassVar[tuple[Field, ...]] = (_delay_field("delay (s)"),)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        m, f = delay_split(self.delay_s, float(filled(dt)))
        if state is None:
            hist = np.full(m + 1, u[0] if u.size else 0.0)
        else:
            hist = np.asarray(state, dtype=np.float64)
            if hist.shape != (m + 1,):
                raise ParameterError(
                    f"delay state must hold {m + 1} past samples for dt={dt:g} s, got "
                    f"shape {hist.shape}; continue with the same dt"
                )
        ext = np.concatenate((hist, u))
        n = u.size
        y = f * ext[:n] + (1.0 - f) * ext[1 : n + 1]
        return y, ext[-(m + 1) :].copy()

    def inverse(self) -> Advance:
        """The advance ``x(t + τ_d)``: no causal inverse exists, so the inverse needs a
        preview of ``ceil(τ_d/dt)`` samples of the desired trajectory (:class:`Advance`)."""
        return Advance(self.delay_s)


@register_model
@dataclass(frozen=True, eq=False)
class Advance(_Shift):
    """The inverse of a :class:`Delay`: ``y(t) = x(t + τ_d)``, which needs the future.

    ``simulate`` treats its input as the whole known trajectory: ``y_k = (1-f) x_{k+m} +
    f x_{k+m+1}`` (``τ_d/dt = m + f``), the last sample held beyond the end. It therefore is
    not chunkable; a real-time compensator is its causal form (:func:`causal_form`): fed the
    desired trajectory :meth:`preview_samples` samples ahead, the advance becomes a causal
    delay of ``preview - τ_d/dt`` samples. ``Delay(Advance(x)) == x`` exactly for a delay
    that is a whole number of samples; for a fractional one the round trip is ``x``
    smoothed by the kernel ``[f(1-f), 1 - 2f(1-f), f(1-f)]``, an error of at most
    ``f(1-f) max|x_{k+1} - 2x_k + x_{k-1}|``. The last ``preview`` samples of a finite
    record lack their future and are held.

    Parameters
    ----------
    delay_s : float
        The delay being inverted (s), ``>= 0``.
    """

    type_name: ClassVar[str] = "advance"
    fields: ClassVar[tuple[Field, ...]] = (_delay_field("delay being compensated (s)"),)

    def preview_samples(self, dt: float | None) -> int:
        if dt is None or not dt > 0:
            raise ParameterError("the inverse of a delay needs the sample spacing dt > 0 (s)")
        m, f = delay_split(self.delay_s, float(dt))
        return m + (1 if f > 0 else 0)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        m, f = delay_split(self.delay_s, float(filled(dt)))
        if not u.size:
            return u.copy(), None
        ext = np.concatenate((u, np.full(m + 1, u[-1])))
        k = np.arange(u.size)
        return (1.0 - f) * ext[k + m] + f * ext[k + m + 1], None

    def causal(self, dt: float) -> Delay:
        """The causal delay this stage becomes when its input is previewed."""
        m, f = delay_split(self.delay_s, float(dt))
        return Delay((self.preview_samples(dt) - (m + f)) * float(dt))

    def inverse(self) -> Delay:
        return Delay(self.delay_s)
