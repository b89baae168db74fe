"""The model algebra: every model is a causal operator with an explicit state.

A :class:`Model` maps an input signal to an output signal, sample by sample, starting
from a state and returning the state after the last sample. Models compose with
:class:`Chain` (``a >> b`` feeds ``a``'s output into ``b``), and the inverse of a chain
is the chain of inverses in reverse order. Memoryless maps, hysteresis operators and
linear dynamics (delay, lag, resonance, ...) all implement the same interface, so later
extensions plug into the same algebra and the same JSON documents.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np

from ._typing import ArrayLike, Float1D
from .exceptions import NotInvertibleError, ParameterError
from .validation import as_input_signal

__all__ = [
    "UNITS",
    "Chain",
    "Control",
    "Field",
    "Model",
    "Response",
    "RunCost",
    "model_class",
    "model_from_dict",
    "register_model",
    "registered_types",
]

_REGISTRY: dict[str, type[Model]] = {}

#: Kinds of a model field in its JSON form.
FieldKind = Literal["number", "numbers", "matrix", "model", "models", "any"]


#: Units a control may declare: the model's input and output units (those of the parameter
#: set), their ratio and inverse, seconds, hertz, seconds to the power of a polynomial
#: term (transfer-function coefficients), and ``"1"`` for a pure number.
UNITS = ("input", "output", "output/input", "1/input", "s", "Hz", "s^k", "1")


@dataclass(frozen=True)
class Control:
    """How the explorer shows and limits one number of a model field (a slider).

    Declared on a :class:`Field` (``control=`` for every element, ``elements=`` one per
    element of a fixed-length vector); the explorer's sliders on both interfaces are built
    from these (:mod:`app.services.explore.controls`), so a new model type gets its sliders by
    declaring them here.

    Attributes
    ----------
    label : str
        What the user sees. For a vector or matrix, a pattern with ``{i}`` (and ``{j}``):
        the element number as the user counts it (see :attr:`Field.index_base` and
        :attr:`Field.index_zero`), e.g. ``"r{i}"`` gives ``r1, r2, ...``.
    unit : str
        One of :data:`UNITS`.
    range : tuple of float
        Slider range ``(lo, hi)``. With ``relative`` it is in multiples of the field's
        *scale*: a round number (1, 2 or 5 times a power of ten) just above the largest
        magnitude among the values that share it (see :attr:`Field.scale_with`), so the range
        follows the parameter set's size, not the value under the thumb; otherwise absolute.
    step : float
        Slider step, relative to the scale like ``range`` (rounded to a power of ten).
    relative : bool
        Whether ``range`` and ``step`` scale with the values (see ``range``).
    lower, upper : float, optional
        Hard limits of a valid value; a slider value past one is clamped to it.
    strict : bool
        The hard limits are exclusive (``> lower``): the clamp keeps one step inside.
    scale : float
        Scale used when every value that sets it is zero.
    scale_index : int, optional
        For ``elements``: take the scale from this element (a3 follows a0).
    integer : bool
        Whole numbers only.
    count_of : str, optional
        The upper end of the range is the length of this field (a 1-based index).
    log : bool
        A logarithmic slider, for a quantity that spans decades (time constants,
        frequencies): the thumb moves in ``log10`` of the value, the value shown and stored
        is the real one. The range's lower end is then at least one step above zero.
    """

    label: str
    unit: str
    range: tuple[float, float]
    step: float = 0.001
    relative: bool = True
    lower: float | None = None
    upper: float | None = None
    strict: bool = False
    scale: float = 1.0
    scale_index: int | None = None
    integer: bool = False
    count_of: str | None = None
    log: bool = False


@dataclass(frozen=True)
class Field:
    """One field of a model type's JSON form, declared once on the class (``fields``).

    The generic :meth:`Model.from_dict`/:meth:`Model.to_dict`, the parameter-set validation
    (JSON-path errors), the MAT export and the explorer's controls all read these.

    Attributes
    ----------
    name : str
        JSON key, equal to the dataclass field / constructor keyword.
    kind : {"number", "numbers", "matrix", "model", "models", "any"}
        A finite number, a non-empty array of them, a non-empty array of equal-length
        non-empty arrays of them (a 2-D array, row by row), a nested model, a non-empty
        array of models, or anything (checked generically, then by the model itself).
    optional : bool
        May be missing or ``null``.
    default : object
        Value that :meth:`Model.to_dict` omits for an optional field (``None`` always is).
    doc : str
        One line for users, with units (shown by the explorer and in error messages).
    title : str
        Heading of the field's group of sliders (``"Thresholds r_i"``).
    control : Control, optional
        The slider of every number of a ``number``/``numbers``/``matrix`` field.
    elements : tuple of Control
        One control per element of a fixed-length vector instead (``a0..a3``).
    increasing : bool
        The values must increase strictly: a slider stays between its neighbours.
    fixed : tuple of float
        Elements holding one of these values are constants, shown but not moved
        (the dead-zone map's ``rho_0 = 0``).
    index_base : int
        Number shown for the first element in the label (1: ``r1``; 0: ``a0``).
    index_zero : str, optional
        Number the elements from the position of the ``0`` in this field instead
        (``rho_-11 .. rho_0 .. rho_11``).
    scale_with : tuple of str
        Other fields of the same model whose values share this field's scale
        (``p0`` and the weights ``p_i``).
    """

    name: str
    kind: FieldKind
    optional: bool = False
    default: Any = None
    doc: str = ""
    title: str = ""
    control: Control | None = None
    elements: tuple[Control, ...] = ()
    increasing: bool = False
    fixed: tuple[float, ...] = ()
    index_base: int = 1
    index_zero: str | None = None
    scale_with: tuple[str, ...] = ()

    @property
    def numeric(self) -> bool:
        """Whether the field holds numbers (and so has sliders)."""
        return self.kind in ("number", "numbers", "matrix")

    def control_at(self, k: int) -> Control | None:
        """The control of element ``k`` (``elements[k]`` or ``control``)."""
        if self.elements:
            return self.elements[k] if k < len(self.elements) else None
        return self.control


def register_model(cls: type[Model]) -> type[Model]:
    """Class decorator: make ``cls`` loadable by :func:`model_from_dict` via ``cls.type_name``."""
    name = cls.type_name
    if name in _REGISTRY and _REGISTRY[name] is not cls:
        raise ValueError(f"model type {name!r} registered twice")
    _REGISTRY[name] = cls
    return cls


def model_class(name: str) -> type[Model]:
    """The class registered under ``name`` (``ParameterError`` naming the known types)."""
    if name not in _REGISTRY:
        raise ParameterError(
            f"unknown model type {name!r}; known types: {', '.join(registered_types())}"
        )
    return _REGISTRY[name]


def registered_types() -> list[str]:
    """Names of every model ``type`` that :func:`model_from_dict` understands."""
    return sorted(_REGISTRY)


def model_from_dict(d: dict[str, Any]) -> Model:
    """Build a model from its ``to_dict()`` form, dispatching on ``d["type"]``.

    Raises
    ------
    ParameterError
        If ``d`` is not a mapping, has no known ``type``, or its fields are invalid.
    """
    if not isinstance(d, dict):
        raise ParameterError(f"a model must be a JSON object, got {type(d).__name__}")
    t = d.get("type")
    if t not in _REGISTRY:
        raise ParameterError(
            f"unknown model type {t!r}; known types: {', '.join(registered_types())}"
        )
    return _REGISTRY[t].from_dict(d)


@dataclass(frozen=True)
class RunCost:
    """Priced work and memory of one simulation of one model stage (its sub-models excluded).

    Attributes
    ----------
    work : float
        Element operations: one is about one floating-point update of one sample (of the
        order of a nanosecond). A float, so that hostile sizes never overflow.
    memory : float
        Peak bytes the stage allocates for the run (buffers, work arrays).
    """

    work: float
    memory: float

    def __add__(self, other: RunCost) -> RunCost:
        return RunCost(self.work + other.work, self.memory + other.memory)


#: Bytes of one float64 sample.
SAMPLE_BYTES = 8.0


@dataclass(frozen=True, eq=False)
class Response:
    """Result of :meth:`Model.simulate`.

    Attributes
    ----------
    u : ndarray of shape (N,)
        The input that was applied.
    y : ndarray of shape (N,)
        The output.
    state : object
        The model state after the last sample; pass it as ``state=`` to continue.
    """

    u: Float1D
    y: Float1D
    state: Any

    def __iter__(self) -> Iterator[Any]:
        """Allow ``u, y = model.simulate(u)``."""
        return iter((self.u, self.y))


class Model(ABC):
    """Base class of every model (hysteresis operator, memoryless map, linear dynamics).

    Subclasses are frozen dataclasses that validate in ``__post_init__`` and register
    themselves with :func:`register_model`.
    """

    type_name: ClassVar[str] = ""
    #: True when the output depends on the sample spacing ``dt`` (linear dynamics, delay).
    needs_dt: ClassVar[bool] = False
    #: ``"module:Class"`` of the estimator that fits this type (``model_`` of this type),
    #: which makes ``type_name`` a fit kind (``hyst fit --model``, the explorer's fit menu:
    #: :func:`core.models.fit_kinds`); ``None`` for types that are not fitted on their own.
    estimator: ClassVar[str | None] = None
    #: Input-length arrays the default :meth:`cost` prices as the run's peak memory (the
    #: output included; measured with tracemalloc by ``benchmarks/bench_cost_memory.py``).
    run_arrays: ClassVar[float] = 4.0

    # -- behaviour -----------------------------------------------------------------
    @abstractmethod
    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        """Map a validated input from ``state``; return ``(y, final_state)``."""

    @abstractmethod
    def default_state(self) -> Any:
        """State used when :meth:`simulate` is called without ``state=``."""

    def simulate(
        self, u: ArrayLike, *, state: Any = None, dt: float | None = None
    ) -> Response:
        """Apply the model to an input signal.

        Parameters
        ----------
        u : array_like of shape (N,)
            Input samples (finite).
        state : object, optional
            State before the first sample, as returned in ``Response.state``; the
            model's :meth:`default_state` when omitted.
        dt : float, optional
            Sample spacing in seconds; required by models with ``needs_dt``.

        Returns
        -------
        Response
            ``(u, y, state)``.
        """
        u = as_input_signal(u)
        if self.needs_dt:
            if dt is None or not np.isfinite(dt) or dt <= 0:
                raise ParameterError(
                    f"{type(self).__name__} has dynamics and needs the sample spacing "
                    f"dt > 0 (seconds), got dt={dt!r}"
                )
        if state is None:
            state = self.default_state()
        y, st = self._run(u, state, dt)
        return Response(u=u, y=y, state=st)

    def __call__(self, u: ArrayLike, *, dt: float | None = None) -> Float1D:
        """Shorthand for ``self.simulate(u, dt=dt).y``."""
        return self.simulate(u, dt=dt).y

    def preview_samples(self, dt: float | None) -> int:
        """Samples of the input needed ahead of time (0 for a causal model).

        Non-zero only for the inverse of a delay (:class:`core.stages.Advance`) and chains
        holding one: a real-time compensator must be fed the desired trajectory this many
        samples ahead (see :func:`core.stages.causal_form`).
        """
        return 0

    def time_constants(self) -> tuple[tuple[str, float], ...]:
        """``(label, seconds)`` of each time constant of this stage (not of its children),
        which a fixed-step simulation must resolve: checked against the sample spacing by
        the explorer's cost model. Empty by default."""
        return ()

    def field_size(self) -> int:
        """Numbers held in this stage's own ``number``/``numbers``/``matrix`` fields (its
        sub-models excluded)."""
        total = 0
        for f in self.fields:
            if f.kind in ("number", "numbers", "matrix"):
                v = getattr(self, f.name, None)
                total += 0 if v is None else int(np.size(v))
        return total

    def cost(self, samples: int, dt: float | None) -> RunCost:
        """Priced work and memory of simulating this stage (not its sub-models) on
        ``samples`` samples spaced ``dt`` seconds, computed from the field sizes only
        (nothing is run).

        The default is linear in the fields: ``samples x (1 + numbers in the fields)``
        element operations and :attr:`run_arrays` sample arrays of memory. Types whose work is not
        linear in their fields override it (creep terms, bisection steps, delay buffers,
        state-space order squared, ...); the explorer's cost model sums it over a model
        tree before any work (:mod:`app.services.explore.cost`).

        Parameters
        ----------
        samples : int
            Samples of the input signal.
        dt : float or None
            Sample spacing in seconds (``None`` for a model without dynamics).

        Returns
        -------
        RunCost
            ``work`` in element operations, ``memory`` in bytes.
        """
        n = float(samples)
        size = float(self.field_size())
        return RunCost(n * (1.0 + size), SAMPLE_BYTES * (self.run_arrays * n + size))

    def inverse(self) -> Model:
        """The exact inverse operator, such that ``self(self.inverse()(u)) == u``.

        Raises
        ------
        NotInvertibleError
            If the model has no inverse; the message says why.
        """
        raise NotInvertibleError(f"{type(self).__name__} has no analytical inverse")

    # -- serialisation -------------------------------------------------------------
    #: The JSON fields of this type, declared once (see :class:`Field`).
    fields: ClassVar[tuple[Field, ...]] = ()

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description including ``"type": self.type_name`` (from ``fields``)."""
        d: dict[str, Any] = {"type": self.type_name}
        for f in self.fields:
            v = getattr(self, f.name)
            if f.optional and (v is None or (f.default is not None and _same(v, f.default))):
                continue
            if f.kind == "model":
                v = v.to_dict()
            elif f.kind == "models":
                v = [m.to_dict() for m in v]
            elif isinstance(v, np.ndarray):
                v = v.tolist()
            elif isinstance(v, np.generic):
                v = v.item()
            d[f.name] = v
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Model:
        """Inverse of :meth:`to_dict` (from ``fields``); raises ``ParameterError`` on bad fields."""
        if not isinstance(d, dict):
            raise ParameterError(f"a {cls.type_name!r} model must be a JSON object")
        missing = [f.name for f in cls.fields if not f.optional and d.get(f.name) is None]
        if missing:
            raise ParameterError(
                f"{cls.type_name} model is missing field(s): {', '.join(missing)}"
            )
        kw: dict[str, Any] = {}
        for f in cls.fields:
            v = d.get(f.name)
            if v is None:
                continue
            if f.kind == "model":
                v = model_from_dict(v)
            elif f.kind == "models":
                if not isinstance(v, list) or not v:
                    raise ParameterError(f"{f.name} must be a non-empty list of models")
                v = tuple(model_from_dict(x) for x in v)
            kw[f.name] = v
        return cls(**kw)

    # -- algebra -------------------------------------------------------------------
    def __rshift__(self, other: Model) -> Chain:
        """``a >> b`` is the chain that applies ``a`` then ``b``."""
        if not isinstance(other, Model):
            return NotImplemented
        return Chain.of(self, other)

    @property
    def is_dynamic(self) -> bool:
        """Whether the model (or any stage of it) needs ``dt``."""
        return self.needs_dt


@register_model
@dataclass(frozen=True, eq=False)
class Chain(Model):
    """Series composition: ``stages[0]`` first, its output feeding ``stages[1]``, ...

    Typical use: input map → hysteresis → output map → linear dynamics. The inverse is
    the chain of the stage inverses in reverse order.

    Parameters
    ----------
    stages : tuple of Model
        At least one stage.
    """

    type_name: ClassVar[str] = "chain"
    fields: ClassVar[tuple[Field, ...]] = (
        Field("stages", "models", doc="the stages, applied first to last"),
    )
    stages: tuple[Model, ...]

    def __post_init__(self) -> None:
        stages = tuple(self.stages)
        if not stages:
            raise ParameterError("a chain needs at least one stage")
        for i, s in enumerate(stages):
            if not isinstance(s, Model):
                raise ParameterError(f"chain stage {i} is {type(s).__name__}, not a Model")
        object.__setattr__(self, "stages", stages)

    @classmethod
    def of(cls, *models: Model) -> Chain:
        """Flatten nested chains into one chain."""
        flat: list[Model] = []
        for m in models:
            flat.extend(m.stages if isinstance(m, Chain) else (m,))
        return cls(tuple(flat))

    @property
    def needs_dt(self) -> bool:  # type: ignore[override]
        return any(s.needs_dt for s in self.stages)

    @property
    def is_dynamic(self) -> bool:
        return self.needs_dt

    def default_state(self) -> tuple[Any, ...]:
        return tuple(s.default_state() for s in self.stages)

    def simulate(
        self, u: ArrayLike, *, state: Any = None, dt: float | None = None
    ) -> Response:
        u = as_input_signal(u)
        if state is None:
            state = self.default_state()
        if len(state) != len(self.stages):
            raise ParameterError(
                f"chain state has {len(state)} entries but the chain has {len(self.stages)} stages"
            )
        x = u
        out_states = []
        for stage, st in zip(self.stages, state, strict=True):
            r = stage.simulate(x, state=st, dt=dt)
            x = r.y
            out_states.append(r.state)
        return Response(u=u, y=x, state=tuple(out_states))

    def _run(self, u: Float1D, state: Any, dt: float | None) -> tuple[Float1D, Any]:
        r = self.simulate(u, state=state, dt=dt)
        return r.y, r.state

    def inverse(self) -> Chain:
        return Chain(tuple(s.inverse() for s in reversed(self.stages)))

    def preview_samples(self, dt: float | None) -> int:
        return sum(s.preview_samples(dt) for s in self.stages)

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Chain:
        stages = d.get("stages") if isinstance(d, dict) else None
        if not isinstance(stages, list) or not stages:
            raise ParameterError("chain.stages must be a non-empty list of models")
        return cls(tuple(model_from_dict(s) for s in stages))


def _same(a: Any, b: Any) -> bool:
    """Whether a field value equals a declared default (numbers or arrays)."""
    try:
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))
    except (TypeError, ValueError):
        return False
