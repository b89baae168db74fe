"""Digitized dead-zone operators and the digitized modified PI model (paper 000 sections 2.3-2.4).

A dead-zone superposition ``γ(v) = Σ_{j=-m}^{m} η_j S_{ρ_j}[v]`` (paper 001 eq. 41-42) is a
memoryless, piecewise-linear map. Its digitized form (paper 000 eq. 18-21) keeps the
segments: ``S = [Δx; Δy]`` of shape (2, m), an origin ``(X_0, Y_0)`` and a state ``C``, the
index of the current segment (1-based as in the paper). The state is not memory: it only
saves the search for the segment, so the output never depends on it.

Consistent reading of eq. 19-21 (printed indices are shifted, eq. 20 is missing and the
printed "ΔX_C" of eq. 21 is ``X_C``): segment ``C`` starts at
``X_C = X_0 + Σ_{i<C} Δx_i``, ``Y_C = Y_0 + Σ_{i<C} Δy_i`` and ``y = Y_C + (Δy_C/Δx_C)(x - X_C)``
on ``[X_C, X_C + Δx_C]``; moving up adds ``(Δx_C, Δy_C)``, moving down subtracts the pair of
the new (lower) segment. Beyond the ends the first and last segments are extended (the
paper's rules stop at ``C = 1`` and ``C = m``), which is exact for a superposition whose
thresholds all lie inside the range. The inverse swaps ``Δx`` and ``Δy`` (eq. 23).

The digitized modified PI model (paper 000's experiment model, Kuhnen's order
``y = S[H[v]]``: the dead zones act on the output of the PI part) is
:class:`DigitizedModifiedPI`. Paper 001 uses the other order, ``P[γ[v]]``; for that, chain
``DigitizedDeadZone >> DigitizedPI`` with :class:`core.base.Chain`.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from ._typing import ArrayLike, Float1D, Float2D
from .base import Chain, Control, Field, Model, Response, model_from_dict, register_model
from .digitized import DigitizedPI, PairedSteps, step_fields
from .exceptions import ParameterError
from .kernels import njit
from .pi import PIModel
from .validation import as_input_signal, as_vector, frozen

__all__ = [
    "DigitizedDeadZone",
    "DigitizedModifiedPI",
    "deadzone_output",
]


def _check_deadzone(thresholds: ArrayLike, weights: ArrayLike) -> tuple[Float1D, Float1D]:
    rho = as_vector(thresholds, "thresholds", increasing=True)
    eta = as_vector(weights, "weights", length=rho.size)
    if not np.any(rho == 0.0):
        raise ParameterError(
            "thresholds must contain ρ_0 = 0 (the linear term, weight η_0); add 0 with its "
            "weight (use weight 0 if there is no linear term)"
        )
    return rho, eta


def deadzone_output(v: ArrayLike, thresholds: ArrayLike, weights: ArrayLike) -> Float1D:
    """Classical dead-zone superposition ``Σ_j η_j S_{ρ_j}[v]`` (paper 001 eq. 41-42).

    Parameters
    ----------
    v : array_like of shape (N,)
        Input.
    thresholds : array_like of shape (2m+1,)
        ``ρ_{-m} < ... < ρ_0 = 0 < ... < ρ_m`` (input units).
    weights : array_like of shape (2m+1,)
        ``η_j`` (output units per input unit).

    Returns
    -------
    ndarray of shape (N,)
    """
    v = as_input_signal(v, "v")
    rho, eta = _check_deadzone(thresholds, weights)
    y = np.zeros(v.size)
    for r, e in zip(rho, eta, strict=True):
        if r > 0:
            y += e * np.maximum(v - r, 0.0)
        elif r < 0:
            y += e * np.minimum(v - r, 0.0)
        else:
            y += e * v
    return y


@njit(cache=True, nogil=True)
def digitized_deadzone_kernel(u, dx, g, xl, yl, c, out):  # pragma: no cover - compiled
    """Walk the segments (paper 000 section 2.3 rules 1-3) and interpolate.

    Parameters
    ----------
    u : ndarray of shape (N,)
    dx, g : ndarray of shape (m,)
        Segment lengths and slopes.
    xl, yl : ndarray of shape (m,)
        Left ends ``(X_C, Y_C)`` of the segments.
    c : int
        Current segment, 0-based.
    out : ndarray of shape (N,)

    Returns
    -------
    int
        Segment of the last sample, 0-based.
    """
    m = dx.shape[0]
    for t in range(u.shape[0]):
        x = u[t]
        while c < m - 1 and x > xl[c] + dx[c]:
            c += 1
        while c > 0 and x < xl[c]:
            c -= 1
        out[t] = yl[c] + g[c] * (x - xl[c])
    return c


@register_model
@dataclass(frozen=True, eq=False)
class DigitizedDeadZone(PairedSteps, Model):
    """Digitized dead-zone superposition ``S = [Δx; Δy]`` (paper 000 eq. 18-21).

    Parameters
    ----------
    dx : array_like of shape (m,)
        Segment lengths ``Δx_C > 0`` (input units).
    dy : array_like of shape (m,)
        Output change of each segment (output units).
    x0, y0 : float
        Left end ``(X_0, Y_0)`` of segment 1.
    state0 : int
        Initial segment ``C``, ``1 <= C <= m`` (does not change the output).

    Examples
    --------
    >>> s = DigitizedDeadZone([1.0, 1.0], [1.0, 3.0])
    >>> s([0.5, 1.5, 3.0]).tolist()
    [0.5, 2.5, 7.0]
    """

    type_name: ClassVar[str] = "digitized-deadzone"
    fields: ClassVar[tuple[Field, ...]] = (
        *step_fields("segment"),
        Field("state0", "number", optional=True, doc="initial segment (1-based)",
              title="Initial segment", control=Control("initial segment", "1", (1.0, 1.0),
                                                       step=1.0, relative=False, lower=1.0,
                                                       integer=True, count_of="dx")),
    )
    dx: Float1D
    dy: Float1D
    x0: float = 0.0
    y0: float = 0.0
    state0: int = 1
    _g: Float1D = field(init=False, repr=False)
    _xl: Float1D = field(init=False, repr=False)
    _yl: Float1D = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._check_steps()
        object.__setattr__(self, "state0", self._check_segment(self.state0, "initial segment"))
        self._set_slopes()
        xl = self.x0 + np.concatenate(([0.0], np.cumsum(self.dx)[:-1]))
        yl = self.y0 + np.concatenate(([0.0], np.cumsum(self.dy)[:-1]))
        object.__setattr__(self, "_xl", frozen(xl))
        object.__setattr__(self, "_yl", frozen(yl))

    def _check_segment(self, c: Any, name: str) -> int:
        m = self.dx.size
        if isinstance(c, bool) or not isinstance(c, numbers.Integral) or not 1 <= int(c) <= m:
            raise ParameterError(
                f"{name} = {c!r} must be a segment number C with 1 <= C <= m = {m} (a whole "
                "number)"
            )
        return int(c)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_S(
        cls, S: ArrayLike, origin: tuple[float, float] = (0.0, 0.0), state0: int = 1
    ) -> DigitizedDeadZone:
        """Build from the paired-property matrix ``S`` (eq. 18).

        Parameters
        ----------
        S : array_like of shape (2, m)
            Row 0 ``Δx`` (input units, > 0), row 1 ``Δy`` (output units).
        origin : (float, float)
            ``(X_0, Y_0)``, the left end of segment 1.
        state0 : int
            Initial segment ``C`` (1-based).

        Returns
        -------
        DigitizedDeadZone
        """
        return cls._from_pairs(S, "S", "m", origin, state0)

    @classmethod
    def from_deadzone(
        cls,
        thresholds: ArrayLike,
        weights: ArrayLike,
        v_range: tuple[float, float] | None = None,
    ) -> DigitizedDeadZone:
        """Digitize a classical dead-zone superposition (paper 001 eq. 41-42).

        Parameters
        ----------
        thresholds : array_like of shape (2m+1,)
            Strictly increasing, containing ``ρ_0 = 0`` (input units).
        weights : array_like of shape (2m+1,)
            ``η_j``.
        v_range : (float, float), optional
            Input range ``(v_min, v_max)``; the segments are cut at the thresholds inside it
            and the outer ones are extended beyond it. Default: the thresholds' span padded
            by half of it on each side (1 if there is no nonzero threshold), which makes the
            representation exact for every input.

        Returns
        -------
        DigitizedDeadZone
            Equal to the classical map on ``v_range``, and everywhere when every nonzero
            threshold lies inside ``v_range``.
        """
        rho, eta = _check_deadzone(thresholds, weights)
        bps = rho[rho != 0.0]
        if v_range is None:
            lo = min(float(rho[0]), 0.0)
            hi = max(float(rho[-1]), 0.0)
            pad = 0.5 * (hi - lo) if hi > lo else 1.0
            v_min, v_max = lo - pad, hi + pad
        else:
            try:
                v_min, v_max = (float(v) for v in v_range)
            except (TypeError, ValueError) as exc:
                raise ParameterError(f"v_range must be a pair (v_min, v_max): {exc}") from exc
            if not (np.isfinite(v_min) and np.isfinite(v_max) and v_max > v_min):
                raise ParameterError(
                    f"v_range = ({v_min:g}, {v_max:g}) must be finite with v_min < v_max"
                )
        pts = np.concatenate(([v_min], bps[(bps > v_min) & (bps < v_max)], [v_max]))
        ys = deadzone_output(pts, rho, eta)
        return cls(np.diff(pts), np.diff(ys), v_min, float(ys[0]), 1)

    @classmethod
    def from_deadzone_map(
        cls, dz: Any, v_range: tuple[float, float] | None = None
    ) -> DigitizedDeadZone:
        """Digitize an object with ``thresholds`` and ``weights`` (``core.deadzone.DeadZoneMap``).

        See :meth:`from_deadzone` for ``v_range``.
        """
        try:
            rho, eta = dz.thresholds, dz.weights
        except AttributeError as exc:
            raise ParameterError(
                f"{type(dz).__name__} has no thresholds/weights; pass plain arrays to "
                "from_deadzone instead"
            ) from exc
        return cls.from_deadzone(rho, eta, v_range)

    def to_deadzone(self) -> tuple[Float1D, Float1D, float]:
        """The classical dead-zone superposition with the same segments, plus an offset.

        ``y = offset + Σ_j η_j S_{ρ_j}[v]`` for every input (the outer segments extend like
        the dead zones beyond the outermost thresholds). The interior segment ends become
        the thresholds, ``η_0`` is the slope of the segment holding 0, a positive
        threshold's weight is the slope increase across it and a negative one's the slope
        increase towards more negative inputs.

        Returns
        -------
        thresholds : ndarray of shape (K,)
            Includes ``ρ_0 = 0``.
        weights : ndarray of shape (K,)
        offset : float
            Output at ``v = 0``.

        Raises
        ------
        ParameterError
            If a segment ends exactly at 0 (a slope change at 0 has no dead-zone form).
        """
        ends = self.x0 + np.cumsum(self.dx)[:-1]
        if np.any(ends == 0.0):
            raise ParameterError(
                "to_deadzone: a segment ends exactly at v = 0, where a slope change cannot be "
                "written with dead-zone operators (ρ_0 = 0 is the linear term); shift x0"
            )
        g = self._g
        neg, pos = ends < 0, ends > 0
        i0 = int(np.count_nonzero(neg))  # segment holding 0
        eta_neg = g[:i0] - g[1 : i0 + 1]
        eta_pos = g[i0 + 1 :] - g[i0:-1]
        rho = np.concatenate((ends[neg], [0.0], ends[pos]))
        eta = np.concatenate((eta_neg, [g[i0]], eta_pos))
        offset = float(self(np.zeros(1))[0])
        return rho, eta, offset

    # ------------------------------------------------------------------ properties
    @property
    def m(self) -> int:
        """Number of segments."""
        return int(self.dx.size)

    @property
    def S(self) -> Float2D:
        """Paired properties ``[Δx; Δy]``, shape (2, m) (eq. 18)."""
        return np.vstack((self.dx, self.dy))

    @property
    def breakpoints(self) -> Float2D:
        """Segment ends ``(X, Y)``: shape (2, m+1), ``X_0 ... X_0 + ΣΔx``."""
        x = self.x0 + np.concatenate(([0.0], np.cumsum(self.dx)))
        y = self.y0 + np.concatenate(([0.0], np.cumsum(self.dy)))
        return np.vstack((x, y))

    # ------------------------------------------------------------------ simulation
    def default_state(self) -> int:
        return self.state0

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, int]:
        c = self._check_segment(state, "state")
        y = np.empty(u.size)
        c = digitized_deadzone_kernel(u, self.dx, self._g, self._xl, self._yl, c - 1, y)
        return y, int(c) + 1

    # ------------------------------------------------------------------ inverse
    def inverse(self) -> DigitizedDeadZone:
        """Inverse by exchanging ``Δx`` and ``Δy`` (eq. 23).

        Raises
        ------
        NotInvertibleError
            If some ``Δy_C <= 0`` (the map is not strictly increasing there).
        """
        return self._swapped(
            "digitized dead zone",
            "every segment must rise; the partial slopes η_0 + Σ η_g must be > 0",
        )

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        return self._steps_dict(self.state0)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> DigitizedDeadZone:
        return cls._from_steps_dict(d, 1)


@register_model
@dataclass(frozen=True, eq=False)
class DigitizedModifiedPI(Model):
    """Digitized modified PI model ``y = S[H[v]]`` (paper 000's experiment model, Kuhnen order).

    The digitized PI part ``H`` acts on the input and the digitized dead-zone part ``S`` on
    its output. The inverse is ``H⁻¹[S⁻¹[y]]``, both by swapping (eq. 22-23).

    Parameters
    ----------
    pi : DigitizedPI
        Hysteresis part.
    deadzone : DigitizedDeadZone
        Memoryless output map.
    """

    type_name: ClassVar[str] = "digitized-mpi"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("pi", "model", doc="the digitized PI part"),
        Field("deadzone", "model", doc="the digitized dead-zone map"),
    )
    pi: DigitizedPI
    deadzone: DigitizedDeadZone

    def __post_init__(self) -> None:
        if not isinstance(self.pi, DigitizedPI):
            raise ParameterError(f"pi must be a DigitizedPI, got {type(self.pi).__name__}")
        if not isinstance(self.deadzone, DigitizedDeadZone):
            raise ParameterError(
                f"deadzone must be a DigitizedDeadZone, got {type(self.deadzone).__name__}"
            )

    @classmethod
    def from_classical(
        cls,
        pi: PIModel,
        u_range: tuple[float, float],
        thresholds: ArrayLike,
        weights: ArrayLike,
        *,
        refine: int = 1,
    ) -> DigitizedModifiedPI:
        """Digitize ``S[P[v]]`` with ``P`` a classical PI and ``S`` a dead-zone superposition.

        Parameters
        ----------
        pi : PIModel
            Classical PI part, digitized by :meth:`DigitizedPI.from_pi` over ``u_range``.
        u_range : (float, float)
            Input range of the PI part.
        thresholds, weights : array_like of shape (2m+1,)
            Dead-zone superposition (``ρ_0 = 0`` included); digitized exactly by
            :meth:`DigitizedDeadZone.from_deadzone` on a range covering its thresholds and
            the PI part's output range.
        refine : int
            Passed to :meth:`DigitizedPI.from_pi`.
        """
        h = DigitizedPI.from_pi(pi, u_range, refine=refine)
        rho, _ = _check_deadzone(thresholds, weights)
        lo = min(h.y_range[0], float(rho[0]))
        hi = max(h.y_range[1], float(rho[-1]))
        pad = 0.5 * (hi - lo)
        s = DigitizedDeadZone.from_deadzone(thresholds, weights, (lo - pad, hi + pad))
        return cls(h, s)

    @classmethod
    def from_modified_pi(
        cls, mpi: Any, u_range: tuple[float, float], *, refine: int = 1
    ) -> DigitizedModifiedPI:
        """Digitize a classical modified PI (``core.gpi.ModifiedPI``: ``pi`` and ``deadzone``).

        The digitized model starts at the lower extreme of ``u_range`` (``mpi.pi.state0`` is
        not used); see :meth:`from_classical`.
        """
        try:
            pi, dz = mpi.pi, mpi.deadzone
            rho, eta = dz.thresholds, dz.weights
        except AttributeError as exc:
            raise ParameterError(
                f"{type(mpi).__name__} is not a modified PI (needs .pi and .deadzone with "
                "thresholds/weights); use from_classical with plain arrays"
            ) from exc
        return cls.from_classical(pi, u_range, rho, eta, refine=refine)

    @property
    def stages(self) -> tuple[Model, Model]:
        """``(pi, deadzone)`` in the order they act."""
        return (self.pi, self.deadzone)

    def as_chain(self) -> Chain:
        """The same model as a :class:`core.base.Chain` ``pi >> deadzone``."""
        return Chain.of(self.pi, self.deadzone)

    def default_state(self) -> tuple[Any, Any]:
        return (self.pi.default_state(), self.deadzone.default_state())

    def simulate(
        self, u: ArrayLike, *, state: Any = None, dt: float | None = None
    ) -> Response:
        u = as_input_signal(u)
        if state is None:
            state = self.default_state()
        if not isinstance(state, tuple | list) or len(state) != 2:
            raise ParameterError(
                "digitized-mpi state must be a pair (pi_state, deadzone_state) as returned "
                "in Response.state"
            )
        r1 = self.pi.simulate(u, state=state[0])
        r2 = self.deadzone.simulate(r1.y, state=state[1])
        return Response(u=u, y=r2.y, state=(r1.state, r2.state))

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        r = self.simulate(u, state=state)
        return r.y, r.state

    def inverse(self) -> Chain:
        """``S⁻¹ >> H⁻¹`` as a chain (eq. 22-23).

        Raises
        ------
        NotInvertibleError
            If either part is not invertible.
        """
        return Chain((self.deadzone.inverse(), self.pi.inverse()))

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type_name,
            "pi": self.pi.to_dict(),
            "deadzone": self.deadzone.to_dict(),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> DigitizedModifiedPI:
        missing = [k for k in ("pi", "deadzone") if k not in d]
        if missing:
            raise ParameterError(f"digitized-mpi model is missing field(s): {', '.join(missing)}")
        pi = model_from_dict(d["pi"])
        dz = model_from_dict(d["deadzone"])
        return cls(pi, dz)  # type: ignore[arg-type]
