"""The static output maps: the asymmetry ``y = x + Σ_k a_k ((x - c)/s)^k`` with its inverse
(bisection on the monotone range) and the offset ``y = x + c``."""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from .._typing import Float1D
from ..base import SAMPLE_BYTES, Control, Field, Model, RunCost, register_model
from ..exceptions import ClippedInputWarning, ParameterError
from ..validation import as_finite_scalar, as_vector


def bisect_steps() -> int:
    """Bisection steps of the memoryless inverse maps (bracket width × 2⁻⁸⁰ ≈ 1e-24)."""
    return 80


@register_model
@dataclass(frozen=True, eq=False)
class Asymmetry(Model):
    """Output asymmetry: a static map that bends the loop.

    ``y = x + Σ_k a_k ((x - c)/s)^k``, k = 2, 3, ...

    An even (k = 2) term makes the ascending and descending branches curve differently, a
    cubic term saturates or stiffens both ends (Gu et al. 2014 polynomial PI; Kuhnen's MPI
    output map to first order). Actuator asymmetry and sensor nonlinearity are both static
    output maps and cannot be told apart from (u, y) alone.

    Parameters
    ----------
    coefficients : array_like of shape (m,)
        ``a_2, a_3, ...`` in output units.
    center : float
        Centre ``c`` of the map (output units).
    scale : float
        Half-range ``s > 0`` of the map (output units).
    """

    type_name: ClassVar[str] = "asymmetry"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("coefficients", "numbers", doc="a_2, a_3, ... (output units)",
              title="Bend coefficients a_k", index_base=2, scale_with=("scale",),
              control=Control("a{i}", "output", (-0.25, 0.25))),
        Field("center", "number", doc="centre of the map (output units)", title="Centre c",
              scale_with=("scale",), control=Control("c", "output", (-1.0, 1.0))),
        Field("scale", "number", doc="half-range of the map (output units)",
              title="Half-range s",
              control=Control("s", "output", (0.0, 2.0), lower=0.0, strict=True)),
    )
    coefficients: Float1D
    center: float
    scale: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", as_vector(self.coefficients, "coefficients"))
        object.__setattr__(self, "center", as_finite_scalar(self.center, "center"))
        object.__setattr__(self, "scale", as_finite_scalar(self.scale, "scale", positive=True))

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        q = (u - self.center) / self.scale
        y = u.copy()
        for k, a in enumerate(self.coefficients, start=2):
            y += a * q**k
        return y, None

    def monotone_range(self) -> tuple[float, float]:
        """``(x_lo, x_hi)``: the interval around ``center`` where the map increases (input
        units, ``±inf`` when unbounded). The inverse maps onto it."""
        # dy/dq = s + Σ k a_k q^(k-1), q = (x - c)/s; polynomial highest power first
        a = self.coefficients
        coef = np.asarray([k * a[k - 2] for k in range(a.size + 1, 1, -1)] + [self.scale],
                          dtype=np.float64)
        nz = np.flatnonzero(coef)
        poly = coef[nz[0] :] if nz.size else coef[:0]  # leading zeros trimmed
        roots = np.roots(poly) if poly.size > 1 else np.array([])
        real = roots[np.abs(roots.imag) <= 1e-12 * np.maximum(1.0, np.abs(roots))].real
        lo = real[real < 0].max() if np.any(real < 0) else -np.inf
        hi = real[real > 0].min() if np.any(real > 0) else np.inf
        return self.center + self.scale * lo, self.center + self.scale * hi

    def inverse(self) -> AsymmetryInverse:
        return AsymmetryInverse(self.coefficients, self.center, self.scale)

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Coefficients x samples: one power per coefficient and sample (element
        operations, bytes)."""
        n, m = float(samples), float(self.coefficients.size)
        return RunCost(40.0 * n * (m + 1.0), SAMPLE_BYTES * (5.0 * n + m))


def _poly_map(x: np.ndarray, coef: Float1D, c: float, s: float) -> np.ndarray:
    """The asymmetry map in Horner form (the order the C export uses)."""
    q = (x - c) / s
    acc = np.zeros_like(q)
    for a in coef[::-1]:
        acc = (acc + a) * q
    return x + acc * q


@register_model
@dataclass(frozen=True, eq=False)
class AsymmetryInverse(Model):
    """Inverse of an :class:`Asymmetry` output map, by bisection on its monotone range.

    Inputs outside the image of :meth:`Asymmetry.monotone_range` are clipped to it with a
    :class:`~core.exceptions.ClippedInputWarning`. Each sample is bracketed (expanding by
    doubling on an unbounded side, at most 64 times) and bisected 80 times, so the result is
    within ``2⁻⁸⁰`` of the bracket width of the exact pre-image (tolerance ≈ 1e-15 relative;
    the C export runs the same steps). ``Asymmetry(AsymmetryInverse(y)) == y`` to rounding on
    the range.

    Parameters
    ----------
    coefficients, center, scale
        The map being inverted (see :class:`Asymmetry`).
    """

    type_name: ClassVar[str] = "asymmetry-inverse"
    fields: ClassVar[tuple[Field, ...]] = Asymmetry.fields
    coefficients: Float1D
    center: float
    scale: float

    def __post_init__(self) -> None:
        fwd = Asymmetry(self.coefficients, self.center, self.scale)
        for k in ("coefficients", "center", "scale"):
            object.__setattr__(self, k, getattr(fwd, k))

    @property
    def forward(self) -> Asymmetry:
        """The map being inverted."""
        return Asymmetry(self.coefficients, self.center, self.scale)

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        coef, c, s = self.coefficients, self.center, self.scale
        x_lo, x_hi = self.forward.monotone_range()
        y = u.copy()
        below = np.zeros(u.shape, dtype=bool)
        above = np.zeros(u.shape, dtype=bool)
        if np.isfinite(x_lo):
            y_lo = _poly_map(np.array([x_lo]), coef, c, s)[0]
            below = y < y_lo
            y[below] = y_lo
        if np.isfinite(x_hi):
            y_hi = _poly_map(np.array([x_hi]), coef, c, s)[0]
            above = y > y_hi
            y[above] = y_hi
        clipped = int(np.count_nonzero(below | above))
        if clipped:
            warnings.warn(
                f"{clipped} sample(s) outside the range of the asymmetry map were clipped "
                f"to it (input range [{x_lo:.6g}, {x_hi:.6g}])",
                ClippedInputWarning, stacklevel=4,
            )
        lo = np.full_like(y, x_lo if np.isfinite(x_lo) else c - s)
        hi = np.full_like(y, x_hi if np.isfinite(x_hi) else c + s)
        for _ in range(64):
            if not np.isfinite(x_lo):
                grow = _poly_map(lo, coef, c, s) > y
                lo = np.where(grow, c - 2.0 * (c - lo), lo)
            if not np.isfinite(x_hi):
                grow = _poly_map(hi, coef, c, s) < y
                hi = np.where(grow, c + 2.0 * (hi - c), hi)
        for _ in range(bisect_steps()):
            mid = 0.5 * (lo + hi)
            less = _poly_map(mid, coef, c, s) < y
            lo = np.where(less, mid, lo)
            hi = np.where(less, hi, mid)
        x = 0.5 * (lo + hi)
        x[below] = x_lo
        x[above] = x_hi
        return x, None

    def inverse(self) -> Asymmetry:
        return self.forward

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Coefficients x samples x bisection steps (bracket expansion on both sides and
        :func:`bisect_steps`), plus the roots of the map's derivative (a dense eigenvalue
        problem of the coefficients' size), plus about a microsecond (1,000 units) for each
        of the four array passes of every step whatever the length: that is most of a call
        on one sample (a closed loop calls the inverse once per sample: 3-13 ms each,
        measured). Work in element operations, memory in bytes."""
        n, m = float(samples), float(self.coefficients.size)
        steps = 2.0 * 64.0 + bisect_steps()
        work = 3.0 * n * (m + 2.0) * steps + 10.0 * m**3 + 4.0 * 1000.0 * steps
        memory = SAMPLE_BYTES * (9.0 * n + 4.0 * m * m)
        return RunCost(work, memory)


@register_model
@dataclass(frozen=True, eq=False)
class Offset(Model):
    """Constant output (sensor) offset ``y = x + c``.

    Parameters
    ----------
    offset : float
        ``c`` in output units.
    """

    type_name: ClassVar[str] = "offset"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("offset", "number", doc="offset (output units)", title="Offset c",
              control=Control("c", "output", (-2.0, 2.0))),
    )
    offset: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "offset", as_finite_scalar(self.offset, "offset"))

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        return u + self.offset, None

    def inverse(self) -> Offset:
        return Offset(-self.offset)


@register_model
@dataclass(frozen=True, eq=False)
class SignedGain(Model):
    """A gain that depends on the sign of its input: ``y = g+ x`` for ``x >= 0``,
    ``y = g- x`` for ``x < 0``.

    After a friction model (:class:`core.stop.StopPIModel`) it makes the slip force depend
    on the sliding direction while the force stays zero where it was zero (the backlash's
    dead band): the plateau when the input falls is ``g- / g+`` times the one when it rises
    (a band wrapped round a drum grips harder one way than the other). Monotone for
    ``g+, g- > 0``, so its inverse is the same kind with ``1/g+`` and ``1/g-``.

    Parameters
    ----------
    positive : float
        ``g+ > 0``, the gain of non-negative inputs (output per input unit).
    negative : float
        ``g- > 0``, the gain of negative inputs (output per input unit).
    """

    type_name: ClassVar[str] = "signed-gain"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("positive", "number", doc="gain of non-negative inputs (output/input)",
              title="Gain of positive inputs g+",
              control=Control("g+", "output/input", (0.1, 3.0), lower=0.0, strict=True,
                              relative=False)),
        Field("negative", "number", doc="gain of negative inputs (output/input)",
              title="Gain of negative inputs g-",
              control=Control("g-", "output/input", (0.1, 3.0), lower=0.0, strict=True,
                              relative=False)),
    )
    positive: float
    negative: float

    def __post_init__(self) -> None:
        for name in ("positive", "negative"):
            g = as_finite_scalar(getattr(self, name), name)
            if g <= 0:
                raise ParameterError(f"{name} must be > 0 (a gain that keeps the sign), "
                                     f"got {g:g}")
            object.__setattr__(self, name, g)

    @property
    def ratio(self) -> float:
        """``g- / g+``: how much more a negative input is amplified than a positive one."""
        return self.negative / self.positive

    def default_state(self) -> None:
        return None

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        return np.where(u >= 0, self.positive * u, self.negative * u), None

    def inverse(self) -> SignedGain:
        return SignedGain(1.0 / self.positive, 1.0 / self.negative)
