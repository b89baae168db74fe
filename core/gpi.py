"""Generalized PI models of paper 001 (eq. 39-58) and Kuhnen's modified PI, with inverses.

Two cascade orders are in use, and both are offered here:

* **GPI, paper 001 order** (eq. 39): the memoryless map acts on the *input*,
  ``y = P[G[v]]``. :class:`DeadZoneGPI` (G = dead-zone superposition γ, eq. 40-41) and
  :class:`TanhGPI` (G = tanh envelope κ, eq. 44-47). Inverse ``v = G⁻¹[P⁻¹[u]]`` (eq. 48).
* **Modified PI, Kuhnen's order** (paper 001 ref. [29]): the dead-zone superposition acts
  on the *output* of the PI operator, ``y = S[P[v]]``. :class:`ModifiedPI`. Inverse
  ``v = P⁻¹[S⁻¹[u]]``.

Every cascade is a :class:`~core.base.Model` whose state is the tuple of its stage states in
stage order (the same layout as ``as_chain()``), so chunked simulation equals one call and
``inverse()`` is a plain :class:`~core.base.Chain` of the stage inverses in reverse order.

Identities of the tanh envelope when κ_R ≠ κ_L
----------------------------------------------
The envelope (eq. 45) switches branch on the direction of its *input*; its inverse (eq. 57)
switches on the direction of *its* input ``x``. At a reversal the envelope output jumps
between branches, so the output direction can disagree with the input direction for one
sample. Writing ``κ`` for the envelope and ``κ⁻¹`` for its inverse (on the inverse's
domain), the following hold:

* κ_R ≡ κ_L: ``κ∘κ⁻¹ = id`` and ``κ⁻¹∘κ = id``, hence ``Π∘Π⁻¹ = id`` and ``Π⁻¹∘Π = id``.
* κ_R <= κ_L on the range of the signal (counter-clockwise envelope loop, the usual
  case): ``κ∘κ⁻¹ = id``, hence ``Π∘Π⁻¹ = P∘κ∘κ⁻¹∘P⁻¹ = id`` at every sample (the
  compensator is exact). ``κ⁻¹∘κ`` can differ from the identity **only at reversal
  samples** of the input (where the jump of ``h`` outweighs the input step, so ``κ⁻¹``
  sees the wrong direction), and while the input is held right after such a sample.
  Since ``Π⁻¹∘Π = κ⁻¹∘(P⁻¹∘P)∘κ = κ⁻¹∘κ`` ends with the memoryless-per-sample ``κ⁻¹``,
  the error stays on those samples; every other sample is exact.
* κ_R >= κ_L (clockwise envelope loop): the mirror image for the envelope, ``κ⁻¹∘κ = id``
  and so ``Π⁻¹∘Π = id`` everywhere, while ``κ∘κ⁻¹`` fails at reversal samples of ``x``.
  In ``Π∘Π⁻¹ = P∘(κ∘κ⁻¹)∘P⁻¹`` the wrong ``h`` at a reversal sample enters the PI
  operator, whose memory carries the error to later samples: the compensation is only
  exact up to the first reversal.

(Proof sketch for κ_R <= κ_L: at a rising→falling reversal of ``x`` the inverse moves from
``κ_R⁻¹(x_{k-1})`` to ``κ_L⁻¹(x_k) < κ_L⁻¹(x_{k-1}) <= κ_R⁻¹(x_{k-1})``, so ``v`` falls
too and the envelope picks the same branch; likewise for falling→rising. Away from
reversals both directions agree because κ_R, κ_L and their inverses are increasing.)

Repeated samples: this implementation keeps the current direction when the input does not
change (a held input gives a held output). Eq. (45) would pick κ_R and eq. (57) κ_L⁻¹ on
ties; that literal reading makes ``h`` jump while the input is held.
"""

from __future__ import annotations

import os
import sys
import warnings
from dataclasses import dataclass
from types import FrameType
from typing import Any, ClassVar

import numpy as np

from ._typing import ArrayLike, Float1D
from .base import Chain, Control, Field, Model, model_from_dict, register_model
from .deadzone import DeadZoneMap
from .exceptions import ClippedInputWarning, ParameterError
from .pi import PIModel
from .validation import as_finite_scalar, as_vector

__all__ = [
    "PAPER001_EX4_ETA",
    "PAPER001_EX4_ETA0",
    "PAPER001_EX4_RHO",
    "DeadZoneGPI",
    "ModifiedPI",
    "TanhEnvelope",
    "TanhEnvelopeInverse",
    "TanhGPI",
    "paper001_example4",
    "paper001_example4_deadzone",
    "paper001_example4_pi",
    "paper001_example6",
]

# ---------------------------------------------------------------------------------------
# tanh envelope
# ---------------------------------------------------------------------------------------

EnvelopeState = tuple[float, int]  # (previous input, current direction +1/-1)


def _envelope_params(x: ArrayLike, name: str, branch: str) -> Float1D:
    """Validate four tanh-envelope constants ``(c0, c1, c2, c3)`` of ``c0 tanh(c1 v + c2) + c3``."""
    p = as_vector(x, name)
    if p.size != 4:
        raise ParameterError(
            f"{name} must hold 4 numbers ({name}0 tanh({name}1 v + {name}2) + {name}3 for "
            f"{branch}), got {p.size}"
        )
    if p[0] == 0:
        raise ParameterError(f"{name}0 = 0 makes {branch} constant; {name}0 must be nonzero")
    if p[1] == 0:
        raise ParameterError(f"{name}1 = 0 makes {branch} constant; {name}1 must be nonzero")
    if p[0] * p[1] < 0:
        raise ParameterError(
            f"{branch} must be increasing: {name}0 * {name}1 = {p[0] * p[1]:g} must be > 0; "
            f"give {name}0 and {name}1 the same sign"
        )
    return p


def _caller_stacklevel() -> int:
    """``stacklevel`` that makes a warning point at the first frame outside ``core/``."""
    core_dir = os.path.dirname(os.path.abspath(__file__))
    frame: FrameType | None = sys._getframe(1)  # the function that calls warnings.warn
    level = 1
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(core_dir):
        frame = frame.f_back
        level += 1
    return level


def _envelope_controls(c: str) -> tuple[Control, ...]:
    """Sliders of one tanh branch ``c0 tanh(c1 v + c2) + c3``: amplitude, gain, phase, offset."""
    return (
        Control(f"{c}0", "output", (0.0, 1.5), lower=0.0, strict=True),
        Control(f"{c}1", "1/input", (0.0, 1.5), lower=0.0, strict=True),
        Control(f"{c}2", "1", (-2.0, 2.0), step=0.01, relative=False),
        Control(f"{c}3", "output", (-1.0, 1.0), scale_index=0),
    )


#: The initial direction of a tanh envelope: -1 (falling branch) or +1 (rising branch).
_DIRECTION_CONTROL = Control("initial direction", "1", (-1.0, 1.0), step=2.0, relative=False,
                            integer=True)


#: The fields of a tanh envelope and of its inverse (which is given the forward constants).
ENVELOPE_FIELDS: tuple[Field, ...] = (
        Field("a", "numbers", doc="rising-branch envelope c0..c3", title="Rising branch a0..a3",
              elements=_envelope_controls("a"), index_base=0, scale_with=("b",)),
        Field("b", "numbers", doc="falling-branch envelope c0..c3",
              title="Falling branch b0..b3", elements=_envelope_controls("b"), index_base=0,
              scale_with=("a",)),
        Field("direction0", "number", optional=True, doc="initial direction (+1 or -1)",
              title="Initial direction", control=_DIRECTION_CONTROL),
)


def _direction0(d: object) -> int:
    if d not in (1, -1) or isinstance(d, bool):
        raise ParameterError(
            f"the initial direction must be +1 (rising, branch a) or -1 (falling, branch b), "
            f"got {d!r}"
        )
    return int(d)


def _check_state(state: Any, who: str) -> EnvelopeState:
    try:
        prev, d = state
        prev = float(prev)
    except (TypeError, ValueError) as exc:
        raise ParameterError(
            f"{who} state must be (previous input, direction +1/-1), got {state!r}"
        ) from exc
    return prev, _direction0(d)


def _directions(x: Float1D, prev: float, d0: int) -> np.ndarray:
    """Direction (+1/-1) of each sample; a repeated sample keeps the current direction.

    ``prev`` is the sample before ``x[0]`` (NaN: none, then ``d0`` holds until ``x`` moves).
    """
    if x.size == 0:
        return np.empty(0, dtype=np.int64)
    step = np.diff(x, prepend=prev)
    d = np.sign(np.nan_to_num(step, nan=0.0)).astype(np.int64)
    moved = np.flatnonzero(d != 0)
    if moved.size == 0:
        return np.full(x.size, d0, dtype=np.int64)
    last = np.full(x.size, -1, dtype=np.int64)
    last[moved] = moved
    last = np.maximum.accumulate(last)
    return np.where(last >= 0, d[np.maximum(last, 0)], d0)


def _tanh_dict(model: TanhEnvelope | TanhEnvelopeInverse) -> dict[str, Any]:
    d: dict[str, Any] = {"type": model.type_name, "a": model.a.tolist(), "b": model.b.tolist()}
    if model.direction0 != 1:
        d["direction0"] = model.direction0
    return d


@register_model
@dataclass(frozen=True, eq=False)
class TanhEnvelope(Model):
    """Direction-switching tanh envelope κ (paper 001 eq. 45-47), the memory of one sample.

    ``h = κ_R(v) = a0 tanh(a1 v + a2) + a3`` while the input increases and
    ``h = κ_L(v) = b0 tanh(b1 v + b2) + b3`` while it decreases. When κ_R ≠ κ_L, ``h``
    jumps at every reversal; see the module docstring for which inverse identities hold.

    Parameters
    ----------
    a : array_like of shape (4,)
        ``(a0, a1, a2, a3)`` of the increasing branch κ_R; ``a0 a1 > 0`` (κ_R increasing).
        ``a0`` and ``a3`` are in output units, ``a1`` in 1/input units, ``a2`` is unitless.
    b : array_like of shape (4,)
        ``(b0, b1, b2, b3)`` of the decreasing branch κ_L; ``b0 b1 > 0``.
    direction0 : {1, -1}
        Direction assumed before the input first moves (1: start on κ_R).

    Notes
    -----
    The state is ``(previous input, current direction)``, so records can be processed in
    chunks. A repeated input sample keeps the current direction.

    Examples
    --------
    >>> k = TanhEnvelope([6, 0.4, 0, 0], [6, 0.4, 0, 0])
    >>> round(float(k([1.0])[0]), 6) == round(6 * float(np.tanh(0.4)), 6)
    True
    """

    type_name: ClassVar[str] = "tanh-envelope"
    #: Directions and both branches evaluated: about 6 input-length arrays measured.
    run_arrays: ClassVar[float] = 8.0
    fields: ClassVar[tuple[Field, ...]] = ENVELOPE_FIELDS
    a: Float1D
    b: Float1D
    direction0: int = 1

    def __post_init__(self) -> None:
        object.__setattr__(self, "a", _envelope_params(self.a, "a", "kappa_R"))
        object.__setattr__(self, "b", _envelope_params(self.b, "b", "kappa_L"))
        object.__setattr__(self, "direction0", _direction0(self.direction0))

    def kappa_r(self, v: ArrayLike) -> Float1D:
        """Increasing branch ``κ_R(v) = a0 tanh(a1 v + a2) + a3`` (eq. 46), elementwise."""
        a0, a1, a2, a3 = self.a
        return a0 * np.tanh(a1 * np.asarray(v, dtype=np.float64) + a2) + a3

    def kappa_l(self, v: ArrayLike) -> Float1D:
        """Decreasing branch ``κ_L(v) = b0 tanh(b1 v + b2) + b3`` (eq. 47), elementwise."""
        b0, b1, b2, b3 = self.b
        return b0 * np.tanh(b1 * np.asarray(v, dtype=np.float64) + b2) + b3

    @property
    def is_single_valued(self) -> bool:
        """Whether κ_R ≡ κ_L (identical parameters): then κ is memoryless and exactly invertible."""
        return bool(np.array_equal(self.a, self.b))

    def default_state(self) -> EnvelopeState:
        """``(nan, direction0)``: no previous sample yet."""
        return (float("nan"), self.direction0)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, EnvelopeState]:
        prev, d0 = _check_state(state, "tanh envelope")
        d = _directions(u, prev, d0)
        y = np.where(d > 0, self.kappa_r(u), self.kappa_l(u))
        if u.size == 0:
            return y, (prev, d0)
        return y, (float(u[-1]), int(d[-1]))

    def inverse(self) -> TanhEnvelopeInverse:
        """The inverse envelope κ⁻¹ (eq. 57-58); see the module docstring for its identities."""
        return TanhEnvelopeInverse(self.a, self.b, self.direction0)

    def to_dict(self) -> dict[str, Any]:
        return _tanh_dict(self)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TanhEnvelope:
        missing = [k for k in ("a", "b") if k not in d]
        if missing:
            raise ParameterError(f"tanh-envelope model is missing field(s): {', '.join(missing)}")
        return cls(d["a"], d["b"], d.get("direction0", 1))


@register_model
@dataclass(frozen=True, eq=False)
class TanhEnvelopeInverse(Model):
    """Inverse tanh envelope κ⁻¹ (paper 001 eq. 57-58), parameterised by the *forward* constants.

    ``v = κ_R⁻¹(x) = (atanh((x - a3)/a0) - a2) / a1`` while ``x`` increases and
    ``v = κ_L⁻¹(x) = (atanh((x - b3)/b0) - b2) / b1`` while it decreases.

    Each branch exists only on its domain ``|x - a3| < |a0|`` (resp. ``|x - b3| < |b0|``).
    Samples outside (or closer to the edge than ``clip_margin |a0|``) are clipped to
    ``a3 ± (1 - clip_margin)|a0|`` and a :class:`~core.exceptions.ClippedInputWarning`
    reports how many were clipped and the domain.

    Parameters
    ----------
    a, b : array_like of shape (4,)
        The forward envelope's constants (see :class:`TanhEnvelope`).
    direction0 : {1, -1}
        Direction assumed before ``x`` first moves.
    clip_margin : float
        Relative margin inside the domain, ``0 < clip_margin < 1`` (default 1e-9, which
        caps ``|atanh|`` at about 10.7).
    """

    type_name: ClassVar[str] = "tanh-envelope-inverse"
    #: Directions and both branches evaluated: about 6 input-length arrays measured.
    run_arrays: ClassVar[float] = 8.0
    fields: ClassVar[tuple[Field, ...]] = (
        *ENVELOPE_FIELDS,
        Field("clip_margin", "number", optional=True, doc="domain margin of atanh",
              title="Clip margin", control=Control("clip margin", "1", (0.0, 0.1), step=1e-4,
                                                   relative=False, lower=0.0, upper=1.0,
                                                   strict=True)),
    )
    a: Float1D
    b: Float1D
    direction0: int = 1
    clip_margin: float = 1e-9

    def __post_init__(self) -> None:
        object.__setattr__(self, "a", _envelope_params(self.a, "a", "kappa_R"))
        object.__setattr__(self, "b", _envelope_params(self.b, "b", "kappa_L"))
        object.__setattr__(self, "direction0", _direction0(self.direction0))
        m = as_finite_scalar(self.clip_margin, "clip_margin", positive=True)
        if m >= 1:
            raise ParameterError(f"clip_margin = {m:g} must be < 1 (a fraction of |a0|)")
        object.__setattr__(self, "clip_margin", m)

    @property
    def domain_r(self) -> tuple[float, float]:
        """Open domain ``(a3 - |a0|, a3 + |a0|)`` of κ_R⁻¹ (output units of the envelope)."""
        return (float(self.a[3] - abs(self.a[0])), float(self.a[3] + abs(self.a[0])))

    @property
    def domain_l(self) -> tuple[float, float]:
        """Open domain ``(b3 - |b0|, b3 + |b0|)`` of κ_L⁻¹."""
        return (float(self.b[3] - abs(self.b[0])), float(self.b[3] + abs(self.b[0])))

    def _branch(self, c: Float1D, x: Float1D) -> tuple[Float1D, int]:
        s = (x - c[3]) / c[0]
        lim = 1.0 - self.clip_margin
        out = np.abs(s) > lim
        return (np.arctanh(np.clip(s, -lim, lim)) - c[2]) / c[1], int(out.sum())

    def kappa_r_inv(self, x: ArrayLike) -> Float1D:
        """κ_R⁻¹ elementwise (eq. 58), clipping to its domain with a warning."""
        x = np.asarray(x, dtype=np.float64)
        v, n = self._branch(self.a, x)
        self._warn(n, 0, x.size)
        return v

    def kappa_l_inv(self, x: ArrayLike) -> Float1D:
        """κ_L⁻¹ elementwise (eq. 58), clipping to its domain with a warning."""
        x = np.asarray(x, dtype=np.float64)
        v, n = self._branch(self.b, x)
        self._warn(0, n, x.size)
        return v

    def _warn(self, n_r: int, n_l: int, total: int) -> None:
        if n_r + n_l == 0:
            return
        parts = []
        if n_r:
            lo, hi = self.domain_r
            parts.append(
                f"{n_r} on the rising branch, domain {lo:g} < x < {hi:g} (|x - a3| < |a0|)"
            )
        if n_l:
            lo, hi = self.domain_l
            parts.append(
                f"{n_l} on the falling branch, domain {lo:g} < x < {hi:g} (|x - b3| < |b0|)"
            )
        warnings.warn(
            f"inverse tanh envelope: {n_r + n_l} of {total} samples were outside the domain and "
            f"were clipped to just inside it (margin {self.clip_margin:g}): "
            + "; ".join(parts)
            + ". Reduce the reference amplitude or refit the envelope.",
            ClippedInputWarning,
            stacklevel=_caller_stacklevel(),
        )

    def default_state(self) -> EnvelopeState:
        """``(nan, direction0)``: no previous sample yet."""
        return (float("nan"), self.direction0)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, EnvelopeState]:
        prev, d0 = _check_state(state, "inverse tanh envelope")
        d = _directions(u, prev, d0)
        up = d > 0
        v = np.empty(u.size)
        v[up], n_r = self._branch(self.a, u[up])
        v[~up], n_l = self._branch(self.b, u[~up])
        self._warn(n_r, n_l, u.size)
        if u.size == 0:
            return v, (prev, d0)
        return v, (float(u[-1]), int(d[-1]))

    def inverse(self) -> TanhEnvelope:
        """The forward envelope κ."""
        return TanhEnvelope(self.a, self.b, self.direction0)

    def to_dict(self) -> dict[str, Any]:
        d = _tanh_dict(self)
        if self.clip_margin != 1e-9:
            d["clip_margin"] = self.clip_margin
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TanhEnvelopeInverse:
        missing = [k for k in ("a", "b") if k not in d]
        if missing:
            raise ParameterError(
                f"tanh-envelope-inverse model is missing field(s): {', '.join(missing)}"
            )
        return cls(d["a"], d["b"], d.get("direction0", 1), d.get("clip_margin", 1e-9))


# ---------------------------------------------------------------------------------------
# cascades
# ---------------------------------------------------------------------------------------


class _Cascade(Model):
    """Shared behaviour of the two-stage cascades: state and inverse follow :class:`Chain`."""

    #: ``(field name, required class)`` of the two parts, for validation and JSON.
    _parts: ClassVar[tuple[tuple[str, type[Model]], ...]] = ()

    def __post_init__(self) -> None:
        for field, cls in self._parts:
            _typed(getattr(self, field), cls, self.type_name, field)

    @property
    def stages(self) -> tuple[Model, ...]:
        """The stages in the order they are applied to the input."""
        raise NotImplementedError

    def as_chain(self) -> Chain:
        """The same operator as a plain :class:`~core.base.Chain` (same state layout)."""
        return Chain.of(*self.stages)

    def default_state(self) -> tuple[Any, ...]:
        """Tuple of the stage states in stage order."""
        return tuple(s.default_state() for s in self.stages)

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        r = self.as_chain().simulate(u, state=state, dt=dt)
        return r.y, r.state

    def inverse(self) -> Chain:
        """Chain of the stage inverses in reverse order."""
        return Chain.of(*(s.inverse() for s in reversed(self.stages)))

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"type": self.type_name}
        for field, _ in self._parts:
            d[field] = getattr(self, field).to_dict()
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Model:
        if not isinstance(d, dict):
            raise ParameterError(f"a {cls.type_name} model must be a JSON object")
        parts = (_nested(d, cls.type_name, f, c) for f, c in cls._parts)
        return cls(*parts)


def _typed(model: object, cls: type[Model], owner: str, field: str) -> None:
    if not isinstance(model, cls):
        raise ParameterError(
            f"{owner}.{field} must be a {cls.__name__} (type {cls.type_name!r}), "
            f"got {type(model).__name__}"
        )


def _nested(d: dict[str, Any], owner: str, field: str, cls: type[Model]) -> Model:
    if field not in d:
        raise ParameterError(
            f"{owner} model is missing field {field!r} (a {cls.type_name!r} model)"
        )
    m = model_from_dict(d[field])
    _typed(m, cls, owner, field)
    return m


@register_model
@dataclass(frozen=True, eq=False)
class DeadZoneGPI(_Cascade):
    """Dead-zone GPI, paper 001 order: ``y = P[γ[v]]`` (eq. 40-41), dead zones on the INPUT.

    The input ``v`` first passes the memoryless dead-zone superposition γ, whose output
    ``w`` drives the PI operator. Contrast :class:`ModifiedPI` (Kuhnen's order, dead zones on
    the output).

    Parameters
    ----------
    pi : PIModel
        The PI operator P acting on ``w = γ(v)``.
    deadzone : DeadZoneMap
        The input map γ.

    Notes
    -----
    State: ``(None, pi_state)``. ``inverse()`` is ``Chain.of(pi.inverse(), deadzone.inverse())``
    (eq. 48: ``v = γ⁻¹[P⁻¹[u]]``); since γ is a bijection and P has a two-sided inverse, both
    ``Π∘Π⁻¹`` and ``Π⁻¹∘Π`` are the identity.
    """

    type_name: ClassVar[str] = "gpi-deadzone"
    estimator: ClassVar[str | None] = "core.fitting:DeadZoneGPIRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("pi", "model", doc="the PI part", title="PI part"),
        Field("deadzone", "model", doc="the dead-zone input map γ", title="Dead-zone input map γ"),
    )
    _parts: ClassVar[tuple[tuple[str, type[Model]], ...]] = (
        ("pi", PIModel),
        ("deadzone", DeadZoneMap),
    )
    pi: PIModel
    deadzone: DeadZoneMap

    @property
    def stages(self) -> tuple[Model, ...]:
        return (self.deadzone, self.pi)


@register_model
@dataclass(frozen=True, eq=False)
class ModifiedPI(_Cascade):
    """Kuhnen's modified PI: ``y = S[P[v]]``, dead-zone superposition on the PI OUTPUT.

    The input drives the PI operator P; its output passes the memoryless dead-zone
    superposition S (the same :class:`~core.deadzone.DeadZoneMap`, here in output units).
    This is the order of Kuhnen (paper 001 ref. [29]) and of paper 000; paper 001's
    :class:`DeadZoneGPI` uses the opposite order ``P[γ[v]]``.

    Parameters
    ----------
    pi : PIModel
        The PI operator P acting on the input ``v``.
    deadzone : DeadZoneMap
        The output map S.

    Notes
    -----
    State: ``(pi_state, None)``. ``inverse()`` is ``Chain.of(deadzone.inverse(), pi.inverse())``
    (``v = P⁻¹[S⁻¹[u]]``); both ``Π∘Π⁻¹`` and ``Π⁻¹∘Π`` are the identity.
    """

    type_name: ClassVar[str] = "mpi"
    estimator: ClassVar[str | None] = "core.fitting:ModifiedPIRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("pi", "model", doc="the PI part", title="PI part"),
        Field("deadzone", "model", doc="the dead-zone output map S",
              title="Dead-zone output map S"),
    )
    _parts: ClassVar[tuple[tuple[str, type[Model]], ...]] = (
        ("pi", PIModel),
        ("deadzone", DeadZoneMap),
    )
    pi: PIModel
    deadzone: DeadZoneMap

    @property
    def stages(self) -> tuple[Model, ...]:
        return (self.pi, self.deadzone)


@register_model
@dataclass(frozen=True, eq=False)
class TanhGPI(_Cascade):
    """Tanh-envelope GPI, paper 001 order: ``y = P[κ[v]]`` (eq. 44-47), envelope on the INPUT.

    Parameters
    ----------
    pi : PIModel
        The PI operator P acting on ``h = κ[v]``.
    envelope : TanhEnvelope
        The direction-switching envelope κ.

    Notes
    -----
    State: ``(envelope_state, pi_state)``. ``inverse()`` is
    ``Chain.of(pi.inverse(), envelope.inverse())`` (eq. 48, 57-58), which clips ``P⁻¹[u]``
    to the envelope's inverse domain with a :class:`~core.exceptions.ClippedInputWarning`.
    With κ_R ≡ κ_L both ``Π∘Π⁻¹`` and ``Π⁻¹∘Π`` are the identity (on the domain). With
    κ_R <= κ_L, ``Π∘Π⁻¹ = id`` but ``Π⁻¹∘Π`` may differ at reversal samples; with
    κ_R >= κ_L, ``Π⁻¹∘Π = id`` but ``Π∘Π⁻¹`` is exact only up to the first reversal
    (module docstring).
    """

    type_name: ClassVar[str] = "gpi-tanh"
    estimator: ClassVar[str | None] = "core.fitting:TanhGPIRegressor"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("pi", "model", doc="the PI part", title="PI part"),
        Field("envelope", "model", doc="the tanh envelope κ", title="Tanh envelope κ"),
    )
    _parts: ClassVar[tuple[tuple[str, type[Model]], ...]] = (
        ("pi", PIModel),
        ("envelope", TanhEnvelope),
    )
    pi: PIModel
    envelope: TanhEnvelope

    @property
    def stages(self) -> tuple[Model, ...]:
        return (self.envelope, self.pi)


# ---------------------------------------------------------------------------------------
# paper 001 examples
# ---------------------------------------------------------------------------------------

#: Example 4 positive dead-zone thresholds ρ_1..ρ_11 (input units).
PAPER001_EX4_RHO = (0.4, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 2.25, 2.5, 2.75, 3.0)
#: Example 4 weight η_0 of the linear dead-zone term.
PAPER001_EX4_ETA0 = 4.765
#: Example 4 weights η_1..η_11 (mirrored: η_{-j} = η_j).
PAPER001_EX4_ETA = (
    -1.128, -1.116, -0.793, -0.598, -0.413, -0.271, -0.172, -0.106, -0.066, -0.041, -0.025
)


def paper001_example4_pi() -> PIModel:
    """PI part of paper 001 Examples 4-6: ``r_i = 0.45 i``, ``p_i = 0.65 exp(-7.75e-4 r_i)``.

    ``i = 0..6``; ``p_0 = 0.65`` is the linear weight. The printed exponent is positive, a
    misprint: the printed inverse values (z6 = 6.139, q1 = -0.7691) need the negative sign
    (the positive one gives 6.146 and -0.7694; shared/notes/seed-notes.md).
    """
    r = 0.45 * np.arange(7, dtype=np.float64)
    p = np.asarray(0.65 * np.exp(-7.75e-4 * r), dtype=np.float64)
    return PIModel(float(p[0]), r[1:], p[1:])


def paper001_example4_deadzone() -> DeadZoneMap:
    """The 23 mirrored dead zones of paper 001 Example 4 (m = 11)."""
    return DeadZoneMap.symmetric(PAPER001_EX4_RHO, PAPER001_EX4_ETA0, PAPER001_EX4_ETA)


def paper001_example4() -> DeadZoneGPI:
    """Dead-zone GPI of paper 001 Examples 4 and 5 (``y = P[γ[v]]``)."""
    return DeadZoneGPI(paper001_example4_pi(), paper001_example4_deadzone())


def paper001_example6() -> TanhGPI:
    """Tanh GPI of paper 001 Example 6: Example 4's PI with ``κ_R = κ_L = 6 tanh(0.4 v)``."""
    k = (6.0, 0.4, 0.0, 0.0)
    return TanhGPI(paper001_example4_pi(), TanhEnvelope(np.array(k), np.array(k)))
