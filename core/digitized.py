"""Digitized (binary-state) representation of the PI model (paper 000, sections 2.1-2.2, 2.4).

A classical PI model ``y = p0 u + sum_i p_i Γ_{r_i}[u]`` driven over an input range
``[u_min, u_max]`` is a chain of straight loop segments. The digitized representation
stores only those segments: ``n`` digits ``b_1..b_n`` (``b_1`` least significant), each
with a paired property ``(Δx_k, Δy_k)``, collected in ``H = [Δx; Δy]`` (eq. 11), plus the
origin ``(X_0, Y_0)``. The state is the binary number ``B = b_n ... b_1``; its state point is
``X_B = X_0 + Σ b_k Δx_k``, ``Y_B = Y_0 + Σ b_k Δy_k``.

Mapping from the classical parameters (paper 000 eq. 4-10 with the shifted indices corrected,
see ``shared/notes/seed-notes.md``): the ``n`` digits correspond to ``n`` play operators
with thresholds ``r_0 = 0 < r_1 < ... < r_{n-1}``, the ``r_0`` operator being the linear
term with weight ``w_0 = p0``::

    Δx_k   = 2 (r_k - r_{k-1})            k = 1..n-1
    Δx_n   = 2 (u_A - r_{n-1})            u_A = (u_max - u_min) / 2, half the input span
    grad_k = w_0 + w_1 + ... + w_{k-1}    (the PI loop slopes S_k; the paper's grad_1 = 0
                                           is the case without a linear term)
    Δy_k   = grad_k Δx_k

and the origin is the lower extreme of the major loop over ``[u_min, u_max]``:
``X_0 = u_min``, ``Y_0 = S_n u_min + Σ p_i r_i`` (all plays at ``u_min + r_i``). Paper 000
(Fig. 2) shifts the loop into the positive quadrant, ``X_0 = Y_0 = 0``; ``from_pi(...,
shift=True)`` does the same (the input is then ``u - u_min``).

Dynamics (paper 000 section 2.2, with the printed "ΔX_BT" of eq. 16/17 read as ``X_BT``):
moving up sets the lowest 0 digit ``A`` (eq. 12-13), moving down clears the lowest 1
digit ``Z`` (eq. 14-15); between state points the output is interpolated linearly,
``y = Y_B + (Δy_A / Δx_A)(x - X_B)`` for ``x >= X_B`` and with ``Z`` for ``x < X_B``.
An input within ``tol = 1e-12 Δx_1`` (plus a few ulps of ``|X|``) of the next state point
counts as reaching it, so inputs that hit the grid exactly (e.g. the range ends) behave
like the classical model despite rounding in ``X_B``.

Beyond the ends of the range (all digits 1 and ``x > X_B``, or all 0 and ``x < X_B``) the
paper is silent; this module continues with the outer slope ``grad_n``, which reproduces
the classical PI on monotone excursions. A reversal out there is not remembered.

Relation to the classical model (paper 000 section 3.3 claims the two are "equal
mathematically"). They are equal along every input path whose reversals happen at state
points: at the state points and along any monotone path from an extreme the digitized output
equals the classical PI started from the same extreme (:meth:`DigitizedPI.to_pi` returns
that classical model, play state included). A reversal *inside* a segment is not
remembered: the digitized model retraces the segment, while the classical one starts a new
branch with slope ``p0``. The difference returns to zero when the input gets back to the
previous state point (wiping-out). For one interior reversal at travel ``d`` into segment
``k`` it is at most ``(grad_k - p0) d <= (grad_k - p0) Δx_k``; with many reversals in
different segments every play ``i`` (threshold ``r_i``, between digits ``i`` and ``i+1``)
is off by at most ``D_i = max_{k>i} Δx_k``, so the error is at most
``Σ_i |p_i| D_i`` (:meth:`DigitizedPI.reversal_error_bound`; tight on random inputs in the
tests), which is ``>= max_k (grad_k - p0) Δx_k`` and equals it when all segments are equally
long. Both shrink as the segments get finer:
``from_pi(..., refine=s)`` splits every segment into ``s`` equal parts (zero-weight plays
added to the same classical model) and divides the bound by ``s``. Inputs must stay inside
the range for these bounds (see the extrapolation rule above).

The inverse (eq. 22) swaps ``Δx`` and ``Δy``; it exists only when every ``Δx_k, Δy_k > 0``
and ``grad_1 = p0 > 0``.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar, Self

import numpy as np

from ._typing import ArrayLike, Float1D, Float2D
from .base import Control, Field, Model, register_model
from .exceptions import NotInvertibleError, ParameterError
from .kernels import njit
from .pi import PIModel
from .validation import as_finite_scalar, as_input_signal, as_vector, frozen

__all__ = [
    "MAX_GRAPH_DIGITS",
    "DigitizedPI",
    "DigitizedState",
    "DigitizedTrace",
    "StateGraph",
    "as_digits",
    "digit_string",
    "digits_from_code",
    "digits_to_code",
    "step_fields",
]

#: Largest number of digits for which :meth:`DigitizedPI.state_graph` lists all 2**n states.
MAX_GRAPH_DIGITS = 12
#: Relative snapping tolerance for reaching a state point (see the module docstring).
SNAP_RTOL = 1e-12


# ----------------------------------------------------------------------------- digits
def _readonly_digits(d: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(d, dtype=np.uint8)
    a.flags.writeable = False
    return a


def as_digits(value: Any, n: int, name: str = "state0") -> np.ndarray:
    """Convert a binary state to a read-only digit vector ``(b_1, ..., b_n)``.

    Parameters
    ----------
    value : None, str, int, DigitizedState or array_like of shape (n,)
        ``None``: all zeros (the lower extreme). A string is written like the paper,
        most significant digit first (``"011"`` means ``b_3 = 0, b_2 = b_1 = 1``). An
        integer is the code ``Σ b_k 2**(k-1)``. A sequence lists ``b_1`` first (least
        significant first).
    n : int
        Number of digits.
    name : str
        Parameter name used in error messages.

    Returns
    -------
    ndarray of uint8, shape (n,)

    Raises
    ------
    ParameterError
        For characters other than 0/1, a wrong length, or a code outside ``[0, 2**n)``.
    """
    if value is None:
        return _readonly_digits(np.zeros(n, dtype=np.uint8))
    if isinstance(value, DigitizedState):
        value = value.digits
    if isinstance(value, str):
        s = value.strip().replace("_", "")
        if len(s) != n or any(c not in "01" for c in s):
            raise ParameterError(
                f"{name} = {value!r} must be a string of exactly {n} characters 0/1, most "
                f"significant digit b_{n} first (e.g. {'0' * (n - 1) + '1'!r} for b_1 = 1)"
            )
        return _readonly_digits(np.array([int(c) for c in reversed(s)], dtype=np.uint8))
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        code = int(value)
        if code < 0 or code >= 2**n:
            raise ParameterError(
                f"{name} = {code} is not a valid state code for {n} digits; it must satisfy "
                f"0 <= code < 2**{n}"
            )
        return _readonly_digits(digits_from_code(code, n))
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ParameterError(f"{name} must be digits 0/1: {exc}") from exc
    if a.ndim != 1 or a.size != n:
        raise ParameterError(
            f"{name} must hold {n} digits (b_1 first), got shape {a.shape}"
        )
    if not np.all((a == 0) | (a == 1)):
        raise ParameterError(f"{name} digits must each be 0 or 1, got {a.tolist()}")
    return _readonly_digits(a.astype(np.uint8))


def digits_from_code(code: int, n: int) -> np.ndarray:
    """Digits ``(b_1, ..., b_n)`` of the state code ``Σ b_k 2**(k-1)``."""
    return np.array([(int(code) >> k) & 1 for k in range(n)], dtype=np.uint8)


def digits_to_code(digits: ArrayLike) -> int:
    """State code ``Σ b_k 2**(k-1)`` of digits given least significant first (Python int)."""
    return sum(int(b) << k for k, b in enumerate(np.asarray(digits).tolist()))


def digit_string(digits: ArrayLike) -> str:
    """Paper notation ``b_n ... b_1`` (most significant first) of digits given ``b_1`` first."""
    return "".join(str(int(b)) for b in reversed(np.asarray(digits).tolist()))


@dataclass(frozen=True, eq=False)
class DigitizedState:
    """State of a :class:`DigitizedPI`, carried between :meth:`Model.simulate` calls.

    Attributes
    ----------
    digits : ndarray of uint8, shape (n,)
        ``(b_1, ..., b_n)``, least significant first.
    x_b, y_b : float
        The state point ``(X_B, Y_B)`` (input and output units).
    segment : int
        Where the last sample lay: ``+k`` on the upper segment of digit ``k`` (edge to the
        upper neighbour), ``-k`` on the lower segment of digit ``k``, ``0`` beyond the
        range ends or before any sample.
    """

    digits: np.ndarray
    x_b: float = 0.0
    y_b: float = 0.0
    segment: int = 0

    @property
    def code(self) -> int:
        """Integer code ``Σ b_k 2**(k-1)``."""
        return digits_to_code(self.digits)

    @property
    def string(self) -> str:
        """Paper notation ``b_n ... b_1``."""
        return digit_string(self.digits)


@dataclass(frozen=True, eq=False)
class DigitizedTrace:
    """Recorded state sequence of a :class:`DigitizedPI` run (for state diagrams).

    Row ``j`` is the ``j``-th state visited; row 0 is the initial state. State ``j`` is
    active from sample ``sample[j]`` (inclusive) to ``sample[j+1]``; states passed through
    within one sample share its index (zero duration).

    Attributes
    ----------
    y : ndarray of shape (N,)
        Output.
    sample : ndarray of int64, shape (M,)
        First sample index spent in each state.
    flip : ndarray of int64, shape (M,)
        Digit that changed on entering the state: ``+k`` set (move up), ``-k`` cleared
        (move down), ``0`` for the initial row.
    digits : ndarray of uint8, shape (M, n)
        Digit rows, ``b_1`` in column 0.
    codes : ndarray of shape (M,)
        Integer codes (int64 for ``n <= 62``, Python ints in an object array otherwise).
    x_b, y_b : ndarray of shape (M,)
        State points.
    state : DigitizedState
        Final state.
    """

    y: Float1D
    sample: np.ndarray
    flip: np.ndarray
    digits: np.ndarray
    codes: np.ndarray
    x_b: Float1D
    y_b: Float1D
    state: DigitizedState

    @property
    def strings(self) -> list[str]:
        """Digit rows in paper notation ``b_n ... b_1``."""
        return [digit_string(row) for row in self.digits]


@dataclass(frozen=True, eq=False)
class StateGraph:
    """All ``2**n`` states of a :class:`DigitizedPI` and their neighbour edges.

    Drawing the nodes at ``(x, y)`` draws the hypercube in the loop plane: every edge is a
    loop segment (paper 000 Fig. 3-4).

    Attributes
    ----------
    codes : ndarray of int64, shape (2**n,)
        ``0 .. 2**n - 1``.
    digits : ndarray of uint8, shape (2**n, n)
        ``b_1`` in column 0.
    x, y : ndarray of shape (2**n,)
        State points ``(X_B, Y_B)``.
    up : ndarray of int64, shape (2**n - 1, 3)
        Rows ``(from_code, to_code, k)``: setting the lowest 0 digit ``k``.
    down : ndarray of int64, shape (2**n - 1, 3)
        Rows ``(from_code, to_code, k)``: clearing the lowest 1 digit ``k``.
    """

    codes: np.ndarray
    digits: np.ndarray
    x: Float1D
    y: Float1D
    up: np.ndarray
    down: np.ndarray

    @property
    def strings(self) -> list[str]:
        """Digit rows in paper notation ``b_n ... b_1``."""
        return [digit_string(row) for row in self.digits]

    @property
    def n(self) -> int:
        """Number of digits."""
        return int(self.digits.shape[1])

    def hypercube_xy(self) -> Float2D:
        """2-D projection of the n-cube: ``Σ_k b_k L_k (cos θ_k, sin θ_k)``.

        ``θ_k = π (k-1)/n`` and ``L_k = 2**((k-1)/n)``; the unequal lengths keep all
        ``2**n`` positions distinct (equal lengths make e.g. ``101`` and ``010`` coincide for
        n = 3). An alternative to drawing the states at ``(x, y)``: every digit is one
        direction, so states that differ in one digit are joined by parallel edges.

        Returns
        -------
        ndarray of shape (2**n, 2)
        """
        k = np.arange(self.n)
        theta = np.pi * k / self.n
        e = np.column_stack((np.cos(theta), np.sin(theta))) * (2.0 ** (k / self.n))[:, None]
        return self.digits @ e

    def hypercube_edges(self) -> np.ndarray:
        """All single-digit flips ``(code, code | 2**(k-1), k)`` (the n-cube's edges).

        Returns
        -------
        ndarray of int64, shape (n * 2**(n-1), 3)
        """
        rows = [
            (int(c), int(c) | (1 << k), k + 1)
            for k in range(self.n)
            for c in self.codes
            if not (int(c) >> k) & 1
        ]
        return np.asarray(rows, dtype=np.int64).reshape(-1, 3)


# ----------------------------------------------------------------------------- kernel
@njit(cache=True, nogil=True)
def _state_point(dx, dy, x0, y0, digits):  # pragma: no cover - compiled
    xb = x0
    yb = y0
    for k in range(dx.shape[0]):
        if digits[k] != 0:
            xb += dx[k]
            yb += dy[k]
    return xb, yb


@njit(cache=True, nogil=True)
def _lowest(digits, value):  # pragma: no cover - compiled
    for k in range(digits.shape[0]):
        if digits[k] == value:
            return k
    return -1


@njit(cache=True, nogil=True)
def digitized_pi_kernel(
    u, dx, dy, g, x0, y0, tol, digits, out, ev_sample, ev_flip
):  # pragma: no cover - compiled
    """Run the digitized PI model (paper 000 section 2.2) sample by sample.

    Parameters
    ----------
    u : ndarray of shape (N,)
        Input.
    dx, dy, g : ndarray of shape (n,)
        Segment lengths, output changes and slopes ``dy / dx``.
    x0, y0 : float
        Origin.
    tol : float
        Snapping tolerance (input units).
    digits : ndarray of uint8, shape (n,)
        State ``b_1..b_n``, updated in place.
    out : ndarray of shape (N,)
        Output buffer.
    ev_sample, ev_flip : ndarray of int64, shape (cap,)
        Transition record (sample index, ``+k`` set / ``-k`` cleared); entries beyond
        ``cap`` are counted but not written.

    Returns
    -------
    n_events : int
    segment : int
        Segment of the last sample (see :class:`DigitizedState`).
    """
    n = dx.shape[0]
    cap = ev_sample.shape[0]
    xb, yb = _state_point(dx, dy, x0, y0, digits)
    a = _lowest(digits, 0)
    z = _lowest(digits, 1)
    nev = 0
    seg = 0
    for t in range(u.shape[0]):
        x = u[t]
        moved = False
        while a >= 0 and x >= xb + dx[a] - tol:
            digits[a] = 1
            if nev < cap:
                ev_sample[nev] = t
                ev_flip[nev] = a + 1
            nev += 1
            moved = True
            xb, yb = _state_point(dx, dy, x0, y0, digits)
            a = _lowest(digits, 0)
            z = _lowest(digits, 1)
        if not moved:
            while z >= 0 and x <= xb - dx[z] + tol:
                digits[z] = 0
                if nev < cap:
                    ev_sample[nev] = t
                    ev_flip[nev] = -(z + 1)
                nev += 1
                xb, yb = _state_point(dx, dy, x0, y0, digits)
                a = _lowest(digits, 0)
                z = _lowest(digits, 1)
        if x >= xb:
            if a >= 0:
                out[t] = yb + g[a] * (x - xb)
                seg = a + 1
            else:
                out[t] = yb + g[n - 1] * (x - xb)
                seg = 0
        else:
            if z >= 0:
                out[t] = yb + g[z] * (x - xb)
                seg = -(z + 1)
            else:
                out[t] = yb + g[n - 1] * (x - xb)
                seg = 0
    return nev, seg


# ----------------------------------------------------------------------------- model
def step_fields(what: str) -> tuple[Field, ...]:
    """The fields ``dx, dy, x0, y0`` of a staircase of ``what`` (digits, segments)."""
    return (
        Field("dx", "numbers", doc=f"{what} widths in x (input units)",
              title=f"{what.capitalize()} widths Δx_i",
              control=Control("Δx{i}", "input", (0.0, 1.25), lower=0.0, strict=True)),
        Field("dy", "numbers", doc=f"{what} heights in y (output units)",
              title=f"{what.capitalize()} heights Δy_i",
              control=Control("Δy{i}", "output", (-0.5, 1.25))),
        Field("x0", "number", optional=True, doc="origin x", title="Origin x0",
              control=Control("x0", "input", (-1.25, 1.25)), scale_with=("dx",)),
        Field("y0", "number", optional=True, doc="origin y", title="Origin y0",
              control=Control("y0", "output", (-1.25, 1.25)), scale_with=("dy",)),
    )


class PairedSteps:
    """What the two digitized staircases share (:class:`DigitizedPI`'s digits,
    :class:`~core.digitized_deadzone.DigitizedDeadZone`'s segments): the paired properties
    ``[Δx; Δy]`` with an origin ``(x0, y0)`` (:func:`step_fields`), their checks and slopes,
    the inverse by exchanging ``Δx`` and ``Δy`` and the dictionary form. The model class is a
    frozen dataclass with the fields ``dx, dy, x0, y0, state0`` and a private ``_g``."""

    type_name: ClassVar[str]
    dx: Float1D
    dy: Float1D
    x0: float
    y0: float
    state0: Any
    _g: Float1D

    if TYPE_CHECKING:  # the dataclass of the model class writes it

        def __init__(
            self, dx: ArrayLike, dy: ArrayLike, x0: float = 0.0, y0: float = 0.0,
            state0: Any = None,
        ) -> None: ...

    def _check_steps(self) -> None:
        """Check ``dx``, ``dy``, ``x0``, ``y0`` in place and set the slopes ``_g``."""
        dx = as_vector(self.dx, "dx", positive=True)
        dy = as_vector(self.dy, "dy", length=dx.size)
        object.__setattr__(self, "dx", dx)
        object.__setattr__(self, "dy", dy)
        object.__setattr__(self, "x0", as_finite_scalar(self.x0, "x0"))
        object.__setattr__(self, "y0", as_finite_scalar(self.y0, "y0"))

    def _set_slopes(self) -> None:
        g = self.dy / self.dx
        if not np.isfinite(g).all():
            raise ParameterError("dy / dx overflows; rescale dx and dy to moderate magnitudes")
        object.__setattr__(self, "_g", frozen(g))

    @classmethod
    def _from_pairs(
        cls, pairs: ArrayLike, name: str, size: str, origin: tuple[float, float], state0: Any
    ) -> Self:
        """The model of the paired-property matrix ``pairs`` (called ``name``, of shape
        ``(2, size)``: row 0 ``Δx``, row 1 ``Δy``) with origin ``(X_0, Y_0)``."""
        try:
            h = np.asarray(pairs, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"{name} must be a numeric (2, {size}) array: {exc}") from exc
        if h.ndim != 2 or h.shape[0] != 2:
            raise ParameterError(
                f"{name} must have shape (2, {size}): row 0 = Δx, row 1 = Δy; got shape "
                f"{h.shape}"
            )
        if len(origin) != 2:
            raise ParameterError("origin must be a pair (X0, Y0)")
        return cls(h[0], h[1], origin[0], origin[1], state0)

    @property
    def slopes(self) -> Float1D:
        """Step slopes ``Δy_k / Δx_k``."""
        return self._g

    @property
    def is_invertible(self) -> bool:
        """Whether every step rises (``Δy_k > 0``; ``Δx_k > 0`` always holds)."""
        return bool((self.dy > 0).all())

    def _swapped(self, what: str, why: str) -> Self:
        """The inverse by exchanging ``Δx`` and ``Δy`` (same state, swapped origin).

        Raises
        ------
        NotInvertibleError
            Naming ``what`` and ``why`` every step must rise, if some ``Δy_k <= 0``.
        """
        bad = np.flatnonzero(self.dy <= 0)
        if bad.size:
            k = int(bad[0])
            raise NotInvertibleError(
                f"{what} is not invertible: Δy_{k + 1} = {self.dy[k]:g} must be > 0 ({why})"
            )
        return type(self)(self.dy, self.dx, self.y0, self.x0, self.state0)

    def _steps_dict(self, state0: Any) -> dict[str, Any]:
        return {
            "type": self.type_name,
            "dx": self.dx.tolist(),
            "dy": self.dy.tolist(),
            "x0": self.x0,
            "y0": self.y0,
            "state0": state0,
        }

    @classmethod
    def _from_steps_dict(cls, d: dict[str, Any], state0: Any) -> Self:
        """The model of :meth:`_steps_dict`'s form (``state0`` where the dict has none)."""
        missing = [k for k in ("dx", "dy") if k not in d]
        if missing:
            raise ParameterError(
                f"{cls.type_name} model is missing field(s): {', '.join(missing)}"
            )
        return cls(d["dx"], d["dy"], d.get("x0", 0.0), d.get("y0", 0.0), d.get("state0", state0))


@register_model
@dataclass(frozen=True, eq=False)
class DigitizedPI(PairedSteps, Model):
    """Digitized classical PI model with paired properties ``H = [Δx; Δy]`` (paper 000 eq. 11).

    Parameters
    ----------
    dx : array_like of shape (n,)
        Input length ``Δx_k > 0`` of each digit's segment (input units).
    dy : array_like of shape (n,)
        Output change ``Δy_k`` of each segment (output units); the slope is
        ``grad_k = Δy_k / Δx_k``.
    x0, y0 : float
        Origin ``(X_0, Y_0)``: the state point of ``B = 0...0`` (lower extreme of the loop).
    state0 : str, int or array_like of shape (n,), optional
        Initial binary state (see :func:`as_digits`: strings most significant first,
        sequences ``b_1`` first); all zeros by default.

    Examples
    --------
    >>> m = DigitizedPI([2.0, 4.0], [1.0, 6.0], x0=-3.0, y0=-3.5)
    >>> m([-3.0, -1.0, 1.0, 3.0]).tolist()
    [-3.5, -2.5, 0.5, 3.5]
    """

    type_name: ClassVar[str] = "digitized"
    estimator: ClassVar[str | None] = "core.fitting:DigitizedPIRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        *step_fields("digit"),
        Field("state0", "any", optional=True, doc="initial digits (a 0/1 string or list)"),
    )
    dx: Float1D
    dy: Float1D
    x0: float = 0.0
    y0: float = 0.0
    state0: Any = None
    _g: Float1D = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._check_steps()
        object.__setattr__(self, "state0", as_digits(self.state0, self.dx.size, "state0"))
        self._set_slopes()

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_H(
        cls, H: ArrayLike, origin: tuple[float, float] = (0.0, 0.0), state0: Any = None
    ) -> DigitizedPI:
        """Build from the paired-property matrix ``H`` (eq. 11).

        Parameters
        ----------
        H : array_like of shape (2, n)
            Row 0 ``Δx`` (input units, > 0), row 1 ``Δy`` (output units).
        origin : (float, float)
            ``(X_0, Y_0)``.
        state0 : optional
            Initial digits (see :func:`as_digits`).

        Returns
        -------
        DigitizedPI

        Raises
        ------
        ParameterError
            If ``H`` is not of shape (2, n) or its entries break the rules of ``dx``/``dy``.
        """
        return cls._from_pairs(H, "H", "n", origin, state0)

    @classmethod
    def from_pi(
        cls,
        pi: PIModel,
        u_range: tuple[float, float],
        *,
        refine: int = 1,
        shift: bool = False,
        state0: Any = None,
    ) -> DigitizedPI:
        """Digitize a classical PI model over the input range ``u_range`` (eq. 4-10).

        Parameters
        ----------
        pi : PIModel
            Classical model with ``m`` plays; the result has ``n = (m + 1) * refine`` digits.
        u_range : (float, float)
            ``(u_min, u_max)``: the major loop's input range. ``u_A = (u_max - u_min) / 2``
            is its half span and must exceed the largest threshold ``r_m`` (the last digit
            covers ``Δx_n = 2 (u_A - r_m) > 0``).
        refine : int
            Split every segment into ``refine`` equal parts (zero-weight plays added to the
            same classical model): finer state grid, smaller reversal error.
        shift : bool
            Shift the loop to the origin like paper 000 Fig. 2: ``X_0 = Y_0 = 0``, so the
            input is ``u - u_min`` and the output ``y - y_min``. Default: keep the classical
            coordinates, ``X_0 = u_min``, ``Y_0 = S_n u_min + Σ p_i r_i``.
        state0 : optional
            Initial digits; default all zeros, i.e. the lower extreme of the major loop.
            ``pi.state0`` is not used: the classical counterpart is :meth:`to_pi`.

        Returns
        -------
        DigitizedPI

        Raises
        ------
        ParameterError
            If ``u_range`` is not an increasing pair, is too narrow, or ``refine < 1``.
        """
        if not isinstance(pi, PIModel):
            raise ParameterError(f"pi must be a PIModel, got {type(pi).__name__}")
        try:
            u_min, u_max = (float(v) for v in u_range)
        except (TypeError, ValueError) as exc:
            raise ParameterError(f"u_range must be a pair (u_min, u_max): {exc}") from exc
        if not (np.isfinite(u_min) and np.isfinite(u_max) and u_max > u_min):
            raise ParameterError(
                f"u_range = ({u_min:g}, {u_max:g}) must be finite with u_min < u_max"
            )
        if not isinstance(refine, numbers.Integral) or refine < 1:
            raise ParameterError(f"refine = {refine!r} must be an integer >= 1")
        u_a = 0.5 * (u_max - u_min)
        r = np.concatenate(([0.0], pi.thresholds))
        if u_a <= r[-1]:
            raise ParameterError(
                f"u_range half span u_A = {u_a:g} must exceed the largest threshold "
                f"r = {r[-1]:g} (the last digit covers Δx_n = 2 (u_A - r_(n-1)) > 0); "
                "widen u_range"
            )
        dx = np.diff(np.concatenate((2.0 * r, [2.0 * u_a])))
        grad = pi.slopes
        dx = np.repeat(dx / refine, refine)
        grad = np.repeat(grad, refine)
        dy = grad * dx
        if shift:
            x0, y0 = 0.0, 0.0
        else:
            x0 = u_min
            y0 = float(grad[-1] * u_min + np.dot(pi.weights, pi.thresholds))
        return cls(dx, dy, x0, y0, state0)

    # ------------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of digits."""
        return int(self.dx.size)

    @property
    def H(self) -> Float2D:
        """Paired properties ``[Δx; Δy]``, shape (2, n) (eq. 11)."""
        return np.vstack((self.dx, self.dy))

    @property
    def tol(self) -> float:
        """Snapping tolerance in input units: ``1e-12 Δx_1`` plus ``(n + 8)`` ulps of ``|X|``.

        Scaling with ``Δx_1`` makes the inverse (tolerance ``1e-12 Δy_1 = grad_1 · 1e-12
        Δx_1``) snap on the images of the inputs this model snaps on (for non-decreasing
        slopes), so ``P⁻¹(P(u)) = u`` also for inputs that hit state points; the ulp term
        covers the rounding of ``X_B``.
        """
        span = float(np.sum(self.dx))
        scale = max(abs(self.x0), abs(self.x0 + span), span)
        ulps = (self.n + 8) * float(np.finfo(np.float64).eps)
        return SNAP_RTOL * float(self.dx[0]) + ulps * scale

    @property
    def x_range(self) -> tuple[float, float]:
        """Input range ``(X_0, X_0 + ΣΔx)`` covered by the state grid."""
        return self.x0, self.x0 + float(np.sum(self.dx))

    @property
    def y_range(self) -> tuple[float, float]:
        """Output values at the two extremes, ``(Y_0, Y_0 + ΣΔy)``."""
        return self.y0, self.y0 + float(np.sum(self.dy))

    def reversal_error_bound(self) -> float:
        """Bound on ``|y_digitized - y_classical|`` for inputs inside :attr:`x_range`.

        ``Σ_{i=1}^{n-1} |p_i| max_{k>i} Δx_k`` with ``p_i = grad_{i+1} - grad_i``: play ``i``
        of the classical model (:meth:`to_pi`) differs from the state implied by the digits
        by at most the longest segment above it. For one interior reversal in segment ``k``
        the smaller :meth:`single_reversal_bound` applies.

        Returns
        -------
        float
            Output units; 0 for ``n = 1``.
        """
        p = np.abs(np.diff(self._g))
        if p.size == 0:
            return 0.0
        d_above = np.maximum.accumulate(self.dx[::-1])[::-1][1:]
        return float(np.dot(p, d_above))

    def single_reversal_bound(self) -> Float1D:
        """``(grad_k - grad_1) Δx_k`` per segment: error bound of one reversal inside it.

        Returns
        -------
        ndarray of shape (n,)
            Output units (for non-decreasing slopes, i.e. positive classical weights).
        """
        return (self._g - self._g[0]) * self.dx

    def state_point(self, state: Any = None) -> tuple[float, float]:
        """``(X_B, Y_B) = (X_0 + Σ b_k Δx_k, Y_0 + Σ b_k Δy_k)`` (eq. 12-15 summed).

        Parameters
        ----------
        state : optional
            Digits (see :func:`as_digits`); default ``state0``.

        Returns
        -------
        (float, float)
            Input and output units.
        """
        d = as_digits(self.state0 if state is None else state, self.n, "state")
        return self._point(d)

    def _point(self, d: np.ndarray) -> tuple[float, float]:
        xb, yb = _state_point(self.dx, self.dy, self.x0, self.y0, np.ascontiguousarray(d))
        return float(xb), float(yb)

    def _make_state(self, d: np.ndarray, segment: int) -> DigitizedState:
        xb, yb = self._point(d)
        return DigitizedState(_readonly_digits(d), xb, yb, int(segment))

    # ------------------------------------------------------------------ simulation
    def default_state(self) -> DigitizedState:
        return self._make_state(np.array(self.state0), 0)

    def _execute(
        self, u: Float1D, state: Any, record: bool
    ) -> tuple[Float1D, DigitizedState, np.ndarray, np.ndarray]:
        d0 = np.array(as_digits(state, self.n, "state"), dtype=np.uint8)
        cap = u.size + self.n + 1 if record else 0
        while True:
            d = d0.copy()
            y = np.empty(u.size)
            ev_s = np.empty(cap, dtype=np.int64)
            ev_f = np.empty(cap, dtype=np.int64)
            nev, seg = digitized_pi_kernel(
                u, self.dx, self.dy, self._g, self.x0, self.y0, self.tol, d, y, ev_s, ev_f
            )
            if not record or nev <= cap:
                break
            cap = int(nev)
        return y, self._make_state(d, seg), ev_s[: min(nev, cap)], ev_f[: min(nev, cap)]

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, DigitizedState]:
        y, st, _, _ = self._execute(u, state, record=False)
        return y, st

    def trace(self, u: ArrayLike, state: Any = None) -> DigitizedTrace:
        """Simulate and record every state visited (for the explorer's state diagram).

        Parameters
        ----------
        u : array_like of shape (N,)
            Input.
        state : optional
            Initial state (default ``state0``).

        Returns
        -------
        DigitizedTrace
        """
        u = as_input_signal(u)
        d0 = as_digits(self.state0 if state is None else state, self.n, "state")
        y, st, ev_s, ev_f = self._execute(u, d0, record=True)
        m = ev_s.size + 1
        rows = np.empty((m, self.n), dtype=np.uint8)
        rows[0] = d0
        cur = np.array(d0)
        for j in range(ev_s.size):
            k = abs(int(ev_f[j])) - 1
            cur[k] = 1 if ev_f[j] > 0 else 0
            rows[j + 1] = cur
        if self.n <= 62:
            codes = rows.astype(np.int64) @ (np.int64(1) << np.arange(self.n, dtype=np.int64))
        else:
            codes = np.array([digits_to_code(r) for r in rows], dtype=object)
        xb = self.x0 + rows @ self.dx
        yb = self.y0 + rows @ self.dy
        return DigitizedTrace(
            y=y,
            sample=np.concatenate(([0], ev_s)).astype(np.int64),
            flip=np.concatenate(([0], ev_f)).astype(np.int64),
            digits=rows,
            codes=codes,
            x_b=xb,
            y_b=yb,
            state=st,
        )

    def state_graph(self, max_digits: int = MAX_GRAPH_DIGITS) -> StateGraph:
        """All ``2**n`` states with their state points and up/down neighbour edges.

        Parameters
        ----------
        max_digits : int
            Refuse larger models (the graph has ``2**n`` nodes).

        Returns
        -------
        StateGraph

        Raises
        ------
        ParameterError
            If ``n > max_digits``.
        """
        n = self.n
        if n > max_digits:
            raise ParameterError(
                f"state_graph lists all 2**n states; n = {n} digits exceeds the limit "
                f"max_digits = {max_digits}. Use trace(u) for the states actually visited."
            )
        codes = np.arange(2**n, dtype=np.int64)
        digits = ((codes[:, None] >> np.arange(n)) & 1).astype(np.uint8)
        x = self.x0 + digits @ self.dx
        y = self.y0 + digits @ self.dy
        up, down = [], []
        for c in range(2**n):
            if c != 2**n - 1:
                a = int(np.flatnonzero(digits[c] == 0)[0])
                up.append((c, c | (1 << a), a + 1))
            if c != 0:
                z = int(np.flatnonzero(digits[c] == 1)[0])
                down.append((c, c & ~(1 << z), z + 1))
        return StateGraph(
            codes=codes,
            digits=digits,
            x=x,
            y=y,
            up=np.asarray(up, dtype=np.int64).reshape(-1, 3),
            down=np.asarray(down, dtype=np.int64).reshape(-1, 3),
        )

    # ------------------------------------------------------------------ classical
    @property
    def classical_offset(self) -> float:
        """Constant ``y_digitized - y_classical`` between this model and :meth:`to_pi`.

        Zero for models built by :meth:`from_pi` without ``shift``.
        """
        g = self._g
        p = np.diff(g)
        r = 0.5 * np.cumsum(self.dx)[:-1]
        return float(self.y0 - (g[-1] * self.x0 + np.dot(p, r)))

    def play_state(self, state: Any = None) -> Float1D:
        """Play outputs of the classical model in the given binary state.

        ``z_i = X_B - Σ_{k<=i} b_k Δx_k + r_i`` with ``r_i = Σ_{k<=i} Δx_k / 2``,
        ``i = 1..n-1``: plays whose digits below them are all set were last pushed up.

        Returns
        -------
        ndarray of shape (n-1,)
        """
        d = as_digits(self.state0 if state is None else state, self.n, "state")
        xb, _ = self._point(d)
        low = np.cumsum(d * self.dx)[:-1]
        r = 0.5 * np.cumsum(self.dx)[:-1]
        return xb - low + r

    def to_pi(self, state: Any = None) -> PIModel:
        """The classical PI model with the same segments, started in the same state.

        ``p0 = grad_1``, ``p_k = grad_{k+1} - grad_k``, ``r_k = (Δx_1 + ... + Δx_k) / 2``
        (``k = 1..n-1``), ``state0 =`` :meth:`play_state`. Its output equals this model's
        minus :attr:`classical_offset` along paths that reverse only at state points.

        Parameters
        ----------
        state : optional
            Binary state to start from (default ``state0``).

        Raises
        ------
        ParameterError
            If ``n < 2`` (a single digit is a straight line, no play operator).
        """
        if self.n < 2:
            raise ParameterError(
                "to_pi needs n >= 2 digits (one play operator); a single digit is linear"
            )
        g = self._g
        return PIModel(
            float(g[0]), 0.5 * np.cumsum(self.dx)[:-1], np.diff(g), self.play_state(state)
        )

    # ------------------------------------------------------------------ inverse
    def inverse(self) -> DigitizedPI:
        """Inverse by exchanging ``Δx`` and ``Δy`` (eq. 22); same digits, swapped origin.

        Raises
        ------
        NotInvertibleError
            If ``grad_1 = p0 <= 0`` (then the inverse's first slope is infinite) or any
            ``Δy_k <= 0`` (a falling or flat segment).
        """
        if self.dy[0] <= 0:
            raise NotInvertibleError(
                f"digitized PI is not invertible: grad_1 = p0 = Δy_1/Δx_1 = {self._g[0]:g} "
                "must be > 0 (the swapped model would need an infinite first slope)"
            )
        return self._swapped("digitized PI", "every segment must rise")

    # ------------------------------------------------------------------ serialisation
    def to_dict(self) -> dict[str, Any]:
        return self._steps_dict(digit_string(self.state0))

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> DigitizedPI:
        return cls._from_steps_dict(d, None)


def paper000_two_operators() -> DigitizedPI:
    """The two-digit case of paper 000 Fig. 3, as used in ``examples/ex07``.

    p0 = 0.5 and one play with r1 = 1, p1 = 1, over the input range [-3, 3] (u_A = 3):
    Δx = (2, 4), Δy = (1, 6).
    """
    from .pi import PIModel

    return DigitizedPI.from_pi(PIModel(0.5, np.array([1.0]), np.array([1.0])), (-3.0, 3.0))


def paper000_three_operators() -> DigitizedPI:
    """The three-digit case of paper 000 Fig. 4, as used in ``examples/ex08``.

    p0 = 0.4, r = (0.5, 1.5), p = (0.6, 1.0) over the input range [0, 10] (u_A = 5).
    """
    from .pi import PIModel

    pi = PIModel(0.4, np.array([0.5, 1.5]), np.array([0.6, 1.0]))
    return DigitizedPI.from_pi(pi, (0.0, 10.0))
