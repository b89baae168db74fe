"""What every C stage emitter shares: the fragments of one stage (:class:`CStage`), the
names and sample time it is given (:class:`StageContext`), the registry of emitters by model
class (:func:`register_c_stage`, :func:`emitter_for`) and the C literals of constants."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np

from ..base import Model
from ..exceptions import ParameterError


class CExportError(ParameterError):
    """The model cannot be exported to C (unsupported stage type, bad name, ...)."""


def c_double(x: float) -> str:
    """A C double literal with 17 significant digits (exact round trip).

    Examples
    --------
    >>> c_double(0.1)
    '0.10000000000000001'
    >>> c_double(2.0)
    '2.0'
    """
    v = float(x)
    if not np.isfinite(v):
        raise CExportError(f"cannot emit the non-finite constant {v!r} as C code")
    s = format(v, ".17g")
    if not any(c in s for c in ".en"):
        s += ".0"
    return s


def c_array(values: Sequence[float] | np.ndarray, per_line: int = 4) -> str:
    items = [c_double(v) for v in np.asarray(values, dtype=np.float64).ravel()]
    lines = [", ".join(items[i : i + per_line]) for i in range(0, len(items), per_line)]
    return "{\n    " + ",\n    ".join(lines) + "\n}"


@dataclass
class CStage:
    """C fragments of one stage, with identifiers already prefixed.

    Attributes
    ----------
    title : str
        One-line description for the comment above the stage.
    fields : list of str
        Declarations inside the state struct, e.g. ``"double s0_z[6];"``.
    constants : list of str
        File-scope ``static const`` definitions.
    reset : list of str
        Statements that put the state (``st->...``) back to its initial value.
    step : list of str
        Statements that read the current sample from the double ``x`` and overwrite ``x``
        with the stage output (they may update ``st->...``). The loop counter ``unsigned
        i`` is declared by the caller when any line contains ``for (i``.
    helpers : list of str
        File-scope ``static`` helper functions (identifiers prefixed with ``ctx.const``).
    needs_math : bool
        Whether the code calls ``<math.h>`` functions (``tanh``, ``atanh``).
    tune : list of str
        Statements that recompute the stage's constants from its model parameters, for
        exports whose parameters can be changed at run time (the FMU,
        :mod:`core.export_fmu`). ``$field[i]`` stands for element ``i`` of the model field
        ``field`` (``$model.thresholds[i]`` for a nested model; matrices row by row); the
        loop counters ``unsigned i, j`` are declared by the caller. A field named in no line
        is fixed at export (its derived constants need the export's numerics).
    tune_helpers : list of str
        File-scope ``static`` functions the tune lines call (emitted with them only).
    """

    title: str
    fields: list[str] = field(default_factory=list)
    constants: list[str] = field(default_factory=list)
    reset: list[str] = field(default_factory=list)
    step: list[str] = field(default_factory=list)
    helpers: list[str] = field(default_factory=list)
    needs_math: bool = False
    tune: list[str] = field(default_factory=list)
    tune_helpers: list[str] = field(default_factory=list)


@dataclass(frozen=True)
class StageContext:
    """Naming and timing context handed to a stage emitter.

    Attributes
    ----------
    field : str
        Prefix of the stage's struct fields (``"s0_"``), unique within a block.
    const : str
        Prefix of the stage's file-scope constants (``"hyst_inv_s0_"``), unique in the file.
    dt : float or None
        Sample time in seconds for dynamic stages.
    """

    field: str
    const: str
    dt: float | None = None


#: Emitter signature: ``(model, ctx) -> CStage``.
Emitter = Callable[[Model, StageContext], CStage]


_EMITTERS: dict[type[Model], Emitter] = {}
E = TypeVar("E", bound=Callable[..., CStage])


def register_c_stage(cls: type[Model]) -> Callable[[E], E]:
    """Decorator registering the C emitter of model class ``cls`` (see :class:`CStage`);
    :func:`emitter_for` dispatches on the class (a subclass uses its parent's emitter
    unless it registers its own). The emitter's ``model`` is typed as the class (or the
    union of the classes) it is registered for."""

    def deco(fn: E) -> E:
        _EMITTERS[cls] = fn
        return fn

    return deco


def emitter_for(model: Model) -> Emitter | None:
    """The C emitter of ``model``'s class or of its nearest registered base class."""
    return next((_EMITTERS[c] for c in type(model).__mro__ if c in _EMITTERS), None)


def supported_c_types() -> list[str]:
    """Model types that :func:`generate_c` can emit (``chain`` of these included)."""
    return sorted(c.type_name for c in _EMITTERS)


def first_sample(f: str, init: list[str]) -> list[str]:
    """Statements run once, at the first sample (models start "at rest at the first input")."""
    return [f"if (!st->{f}started) {{", *(f"    {line}" for line in init),
            f"    st->{f}started = 1;", "}"]
