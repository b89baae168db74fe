"""The explorer's parameter controls, derived from the model registry's field declarations.

Every model type declares, on each of its :class:`core.base.Field`, how its numbers are shown
(:class:`core.base.Control`: label, unit, range, step, hard limits) and the rules between
them (increasing thresholds, constant elements). :func:`model_controls` turns one model
document into the sliders both interfaces draw (the web page through ``POST
/api/controls``, the viser GUI directly): groups of :class:`Slider` with their JSON path,
the label the user sees (``r3``, ``ρ-2``, ``a0``), the range (from the field's meaning and
the size of the parameter set, never centred on the value under the thumb) and the
neighbours a value must stay between. :func:`clamp` keeps a moved value inside those rules
and says why in the user's labels; :func:`check_rules` words a refused document in them.

A new model type gets its sliders by declaring its fields; nothing here names a type.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

from app.services.words import type_words
from core.base import Control, Field, Model, model_class
from core.exceptions import ParameterError

__all__ = [
    "MAX_FIELD_SLIDERS",
    "MAX_SLIDERS",
    "Clamped",
    "ModelControls",
    "Slider",
    "SliderGroup",
    "check_rules",
    "clamp",
    "get_leaf",
    "model_controls",
    "log_step",
    "slider_position",
    "slider_value",
    "unit_text",
    "with_leaf",
]

#: Most sliders one field gets (more numbers than that are edited in the model JSON).
MAX_FIELD_SLIDERS = 25
#: Most sliders one model gets in all.
MAX_SLIDERS = 120
#: Deepest nesting of model parts walked (a chain of chains ...).
MAX_DEPTH = 8
#: Round scales: a field's scale is the first of these (times a power of ten) at or above
#: the largest magnitude of its values.
NICE = (1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0)

_UNIT_TEXT = {"input": "input units", "output": "output units",
              "output/input": "output per input unit", "1/input": "per input unit",
              "s": "s", "Hz": "Hz", "s^k": "s to the power of the term", "1": ""}
_TOKENS = re.compile(r"[^.\[\]]+|\[\d+\]")


def unit_text(unit: str) -> str:
    """A declared unit in words (``""`` for a pure number)."""
    return _UNIT_TEXT.get(unit, unit)


@dataclass(frozen=True)
class Slider:
    """One number of a model document as a slider.

    Attributes
    ----------
    path : str
        JSON path in the model document (``pi.thresholds[2]``).
    label : str
        What the user sees (``r3``).
    unit : str
        Declared unit (:data:`core.base.UNITS`).
    value, min, max, step : float
        Current value and the slider's range and step.
    lower, upper : float or None
        Hard limits of a valid value (``strict``: exclusive).
    strict, integer, fixed : bool
        Exclusive limits; whole numbers only; a constant (shown, not moved).
    below, above : str or None
        Paths of the neighbours this value must stay above / below (increasing fields).
    rule : str
        The ordering rule in words, for messages (``"the thresholds r_i increase"``).
    log : bool
        A logarithmic slider: the thumb moves in ``log10(value)`` between ``log10(min)``
        and ``log10(max)`` (:func:`slider_position`, :func:`slider_value`); ``value``,
        ``min`` and ``max`` stay real values (``min > 0``).
    """

    path: str
    label: str
    unit: str
    value: float
    min: float
    max: float
    step: float
    lower: float | None = None
    upper: float | None = None
    strict: bool = False
    integer: bool = False
    fixed: bool = False
    below: str | None = None
    above: str | None = None
    rule: str = ""
    log: bool = False


@dataclass(frozen=True)
class SliderGroup:
    """The sliders of one field of one model part, shown together.

    Attributes
    ----------
    key : str
        JSON path of the field (``deadzone.thresholds``): stable while the model keeps its
        structure.
    title : str
        Heading (``Dead-zone map: dead-zone thresholds ρ_j``).
    unit : str
        Unit in words; for sliders of different units, which has which
        (``a0, a3: output units; a1: per input unit``).
    sliders : tuple of Slider
    note : str
        Why some numbers have no slider (too many), else ``""``.
    """

    key: str
    title: str
    unit: str
    sliders: tuple[Slider, ...]
    note: str = ""


@dataclass(frozen=True)
class ModelControls:
    """Every slider of one model document, grouped by field.

    Attributes
    ----------
    type : str
        The model's ``type``.
    groups : tuple of SliderGroup
    layout : str
        Identifies the structure (types, fields and lengths): while it stays the same, the
        sliders are only moved, not rebuilt.
    """

    type: str
    groups: tuple[SliderGroup, ...]
    layout: str

    def sliders(self) -> Iterator[Slider]:
        """Every slider, group by group."""
        for g in self.groups:
            yield from g.sliders

    def slider(self, path: str) -> Slider | None:
        """The slider at ``path``, or ``None``."""
        return next((s for s in self.sliders() if s.path == path), None)


@dataclass(frozen=True)
class Clamped:
    """A slider value after the rules: the value to store and, when it was moved, why."""

    value: float
    note: str = ""


# ----------------------------------------------------------------------------- paths
def get_leaf(doc: Any, path: str) -> Any:
    """The value at ``path`` (``pi.thresholds[2]``) of a model document.

    Raises
    ------
    ParameterError
        If the path does not lead to a value.
    """
    node = doc
    try:
        for tok in _TOKENS.findall(path):
            node = node[int(tok[1:-1])] if tok.startswith("[") else node[tok]
    except (KeyError, IndexError, TypeError, ValueError):
        raise ParameterError(f"the model has no parameter at {path!r}") from None
    return node


def with_leaf(doc: Any, path: str, value: float) -> dict[str, Any]:
    """A new model document: ``doc`` with the number at ``path`` set to ``value``.

    Only the objects on the path are new (a slider's move copies the document's spine, not
    the whole document); the rest is shared with ``doc``, which is left as it was (a
    config's model is never changed in place).

    Raises
    ------
    ParameterError
        If the path does not lead to a value.
    """
    tokens = _TOKENS.findall(path)
    if not tokens:
        raise ParameterError("empty parameter path")

    def put(node: Any, k: int) -> Any:
        tok = tokens[k]
        new: Any
        try:
            if tok.startswith("["):
                if not isinstance(node, list):
                    raise TypeError(tok)
                new, key = list(node), int(tok[1:-1])
                new[key]  # noqa: B018 (an index past the end is no parameter)
            else:
                if not isinstance(node, dict) or tok not in node:
                    raise KeyError(tok)
                new, key = dict(node), tok
        except (KeyError, IndexError, TypeError, ValueError):
            raise ParameterError(f"the model has no parameter at {path!r}") from None
        new[key] = value if k == len(tokens) - 1 else put(new[key], k + 1)
        return new

    return put(doc, 0)


# ----------------------------------------------------------------------------- ranges
def _nice_ceil(x: float) -> float:
    """The smallest round number (:data:`NICE` times a power of ten) >= ``x`` > 0."""
    e = math.floor(math.log10(x))
    for m in NICE:
        v = m * 10.0 ** e
        if v >= x * (1 - 1e-12):
            return v
    return 10.0 ** (e + 1)  # pragma: no cover - NICE ends at 10


def _pow10(x: float) -> float:
    """The power of ten nearest to ``x`` > 0 (on a log scale)."""
    return 10.0 ** round(math.log10(x))


def _numbers(v: Any) -> list[float]:
    """The finite numbers of a field value (a number, a list, a list of lists)."""
    if isinstance(v, bool):
        return []
    if isinstance(v, int | float):
        return [float(v)] if math.isfinite(v) else []
    if isinstance(v, list | tuple):
        out: list[float] = []
        for x in v:
            out += _numbers(x)
        return out
    return []


def _scale(node: Mapping[str, Any], field: Field, ctl: Control, k: int | None) -> float:
    """The round scale of a field's values (and of the fields it shares it with)."""
    vals: list[float] = []
    idx = ctl.scale_index if ctl.scale_index is not None else k
    for name in (field.name, *field.scale_with):
        v = node.get(name)
        if idx is not None and field.elements:
            if isinstance(v, list) and idx < len(v):
                vals += _numbers(v[idx])
        else:
            vals += _numbers(v)
    m = max((abs(x) for x in vals), default=0.0)
    return _nice_ceil(m) if m > 0 else ctl.scale


def _limits(node: Mapping[str, Any], field: Field, ctl: Control, k: int | None,
            values: list[float]) -> tuple[float, float, float]:
    """``(min, max, step)`` of the sliders of one control."""
    if ctl.relative:
        s = _scale(node, field, ctl, k)
        lo, hi = ctl.range[0] * s, ctl.range[1] * s
        step = _pow10(ctl.step * s)
    else:
        lo, hi = ctl.range
        step = ctl.step
    if ctl.count_of is not None:
        other = node.get(ctl.count_of)
        hi = float(len(other)) if isinstance(other, list) else hi
    if ctl.lower is not None:
        lo = max(lo, ctl.lower + (step if ctl.strict else 0.0))
    if ctl.upper is not None:
        hi = min(hi, ctl.upper - (step if ctl.strict else 0.0))
    if values:  # the range always holds the values there are
        lo = min(lo, math.floor(min(values) / step) * step)
        hi = max(hi, math.ceil(max(values) / step) * step)
    if ctl.log:  # log10 needs a positive lower end
        lo = max(lo, step)
    if hi <= lo:
        hi = lo + step
    return _round(lo, step), _round(hi, step), step


def _round(x: float, step: float) -> float:
    """``x`` without the float noise of a multiplication (to the step's decimals)."""
    digits = max(0, -math.floor(math.log10(step)) + 2)
    return round(x, digits)


#: Positions of a logarithmic slider's thumb per decade.
LOG_STEPS_PER_DECADE = 200


def slider_position(s: Slider, value: float) -> float:
    """Where the thumb of slider ``s`` sits for ``value``: ``log10(value)`` on a log
    slider (a value at or below zero sits at the left end), else the value itself."""
    if not s.log:
        return value
    return math.log10(max(value, s.min))


def slider_value(s: Slider, position: float) -> float:
    """The value of slider ``s`` with its thumb at ``position`` (inverse of
    :func:`slider_position`), to three significant digits on a log slider."""
    if not s.log:
        return position
    v = 10.0 ** position
    return float(f"{v:.3g}")


def log_step(s: Slider) -> float:
    """Thumb step of a log slider, in decades."""
    return 1.0 / LOG_STEPS_PER_DECADE


# ----------------------------------------------------------------------------- walking
def _part_title(field: Field) -> str:
    if field.title:
        return field.title
    t = field.doc.removeprefix("the ").strip()
    return t[:1].upper() + t[1:]


def _elements(value: Any, kind: str) -> list[tuple[tuple[int, ...], float]]:
    """``(index, number)`` of every element of a numeric field value."""
    if kind == "number":
        # a list where a number belongs is left to the model's own check (a 422 naming it)
        return [((), float(value))] if _numbers(value) == [value] else []
    if kind == "numbers" and isinstance(value, list):
        return [((i,), float(v)) for i, v in enumerate(value) if _numbers(v) == [v]]
    if kind == "matrix" and isinstance(value, list):
        return [((i, j), float(v)) for i, row in enumerate(value) if isinstance(row, list)
                for j, v in enumerate(row) if _numbers(v) == [v]]
    return []


def _index_origin(node: Mapping[str, Any], field: Field) -> int:
    """Element number shown for the first element (1 for ``r1``; ``-m`` around a zero)."""
    if field.index_zero is not None:
        ref = node.get(field.index_zero)
        if isinstance(ref, list) and 0.0 in ref:
            return -ref.index(0.0)
    return field.index_base


def _label(ctl: Control, idx: tuple[int, ...], origin: int, base: int) -> str:
    i = idx[0] + origin if idx else None
    j = idx[1] + base if len(idx) > 1 else None
    return ctl.label.format(i=i, j=j) if idx else ctl.label


def _field_sliders(node: Mapping[str, Any], field: Field, prefix: str,
                   budget: int) -> tuple[list[Slider], str]:
    value = node.get(field.name)
    elems = _elements(value, field.kind)
    if not elems:
        return [], ""
    if len(elems) > min(MAX_FIELD_SLIDERS, budget):
        return [], (f"{len(elems)} numbers: too many for sliders; edit them in the model JSON")
    path = f"{prefix}{field.name}"
    origin = _index_origin(node, field)
    ctl0 = field.control_at(0)
    shared = None
    if field.control is not None:
        shared = _limits(node, field, field.control, None, [v for _, v in elems])
    rule = f"the {(field.title or field.name).lower()} must increase" if field.increasing else ""
    out: list[Slider] = []
    for n, (idx, v) in enumerate(elems):
        ctl = field.control_at(idx[0]) if idx else ctl0
        if ctl is None:
            continue
        lo, hi, step = shared or _limits(node, field, ctl, idx[0] if idx else None, [v])
        p = path + "".join(f"[{i}]" for i in idx)
        below = above = None
        if field.increasing and field.kind == "numbers":
            below = f"{path}[{idx[0] - 1}]" if n > 0 else None
            above = f"{path}[{idx[0] + 1}]" if n < len(elems) - 1 else None
        out.append(Slider(
            path=p, label=_label(ctl, idx, origin, field.index_base), unit=ctl.unit,
            value=v, min=lo, max=hi, step=step, lower=ctl.lower, upper=ctl.upper,
            strict=ctl.strict, integer=ctl.integer, fixed=v in field.fixed,
            below=below, above=above, rule=rule, log=ctl.log))
    return out, ""


def _node_class(node: Any, depth: int) -> type[Model] | None:
    """The registered model class of a document node, or ``None`` (not a model object, an
    unknown type, or deeper than :data:`MAX_DEPTH`): both walkers skip such nodes."""
    if not isinstance(node, Mapping) or depth > MAX_DEPTH:
        return None
    try:
        return model_class(str(node.get("type")))
    except ParameterError:
        return None


def _walk(node: Any, prefix: str, title: str, depth: int, groups: list[SliderGroup],
          layout: list[str], count: list[int]) -> None:
    cls = _node_class(node, depth)
    if cls is None:
        return
    layout.append(f"{prefix}<{cls.type_name}>")
    for field in cls.fields:
        value = node.get(field.name)
        if value is None:
            continue
        if field.kind == "model":
            _walk(value, f"{prefix}{field.name}.", _join(title, _part_title(field)), depth + 1,
                  groups, layout, count)
        elif field.kind == "models" and isinstance(value, list):
            for i, sub in enumerate(value[:MAX_SLIDERS]):
                kind = sub.get("type") if isinstance(sub, Mapping) else "?"
                _walk(sub, f"{prefix}{field.name}[{i}].",
                      _join(title, f"Stage {i + 1}, {type_words(kind)}"), depth + 1, groups,
                      layout, count)
        elif field.numeric:
            sliders, note = _field_sliders(node, field, prefix, MAX_SLIDERS - count[0])
            layout.append(f"{prefix}{field.name}#{len(_elements(value, field.kind))}")
            if not sliders and not note:
                continue
            count[0] += len(sliders)
            groups.append(SliderGroup(
                key=f"{prefix}{field.name}", title=_join(title, field.title or field.name),
                unit=_group_unit(sliders, field), sliders=tuple(sliders), note=note))


def _group_unit(sliders: list[Slider], field: Field) -> str:
    """The group's unit in words; for mixed units, which slider has which
    (``a0, a3: output units; a1: per input unit``)."""
    units = list(dict.fromkeys(s.unit for s in sliders))
    if not units:
        return unit_text(field.control.unit) if field.control else ""
    if len(units) == 1:
        return unit_text(units[0])
    parts = [f"{', '.join(s.label for s in sliders if s.unit == u)}: {unit_text(u)}"
             for u in units if unit_text(u)]
    return "; ".join(parts)


def _join(a: str, b: str) -> str:
    return f"{a}: {b}" if a else b


def model_controls(doc: Mapping[str, Any]) -> ModelControls:
    """The sliders of a model document, from its types' field declarations.

    Parameters
    ----------
    doc : mapping
        A model's ``to_dict()`` form (checked by the caller; unknown parts get no sliders).

    Returns
    -------
    ModelControls
    """
    groups: list[SliderGroup] = []
    layout: list[str] = []
    _walk(doc, "", "", 0, groups, layout, [0])
    return ModelControls(type=str(doc.get("type", "")), groups=tuple(groups),
                         layout="|".join(layout))


# ----------------------------------------------------------------------------- rules
def _fmt(x: float) -> str:
    return f"{x:.6g}"


def clamp(doc: Mapping[str, Any], path: str, value: float,
          controls: ModelControls | None = None) -> Clamped:
    """Keep a slider value inside its field's rules, given the rest of ``doc``.

    Whole numbers are rounded; a constant keeps its value; a value past a hard limit stops
    at it (one step inside an exclusive one); a value of an increasing field stops one step
    short of its neighbour. The note says what happened, in the labels the user sees.

    Parameters
    ----------
    doc : mapping
        The model document before the move.
    path : str
        The slider's path.
    value : float
        Where the slider was moved.
    controls : ModelControls, optional
        ``model_controls(doc)`` if already at hand.

    Returns
    -------
    Clamped

    Raises
    ------
    ParameterError
        If ``path`` is not a slider of ``doc`` or ``value`` is not a finite number.
    """
    ctl = controls or model_controls(doc)
    s = ctl.slider(path)
    if s is None:
        raise ParameterError(f"the model has no slider at {path!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{s.label} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ParameterError(f"{s.label} must be a finite number, got {value!r}")
    if s.fixed:
        cur = float(get_leaf(doc, path))
        return Clamped(cur, f"{s.label} = {_fmt(cur)} is a constant of this model")
    if s.integer:
        v = float(round(v))
    notes: list[str] = []
    if s.lower is not None:
        lo = s.lower + (s.step if s.strict else 0.0)
        if v <= lo:  # also when the slider's own minimum held it there
            v = lo
            notes.append(f"{s.label} stops at {_fmt(lo)}: it must be "
                         f"{'>' if s.strict else '>='} {_fmt(s.lower)}")
    if s.upper is not None:
        hi = s.upper - (s.step if s.strict else 0.0)
        if v >= hi:
            v = hi
            notes.append(f"{s.label} stops at {_fmt(hi)}: it must be "
                         f"{'<' if s.strict else '<='} {_fmt(s.upper)}")
    lo_n, hi_n = -math.inf, math.inf
    for other, sign in ((s.below, -1), (s.above, 1)):
        if other is None:
            continue
        w = float(get_leaf(doc, other))
        edge = _round(w - sign * s.step, s.step)  # one step short of the neighbour
        if sign > 0:
            hi_n = edge
        else:
            lo_n = edge
        if (sign > 0 and v >= edge) or (sign < 0 and v <= edge):
            v = edge
            n = ctl.slider(other)
            name = n.label if n is not None else other
            notes.append(f"{s.label} stops at {_fmt(edge)}, just "
                         f"{'below' if sign > 0 else 'above'} {name} = {_fmt(w)}: {s.rule}")
    if lo_n > hi_n:  # its neighbours leave it no room: unchanged
        cur = float(get_leaf(doc, path))
        return Clamped(cur, f"{s.label} stays at {_fmt(cur)}: its neighbours leave no room")
    return Clamped(_round(v, s.step), "; ".join(notes))


def check_rules(doc: Mapping[str, Any]) -> None:
    """Refuse a document that breaks its fields' declared rules, in the user's labels.

    Checks the hard limits and the increasing order of every numeric field that has
    controls (numbered as on the sliders: ``r3`` is the third threshold), so a refusal
    reads ``r3 = 3.345 must stay below r4 = 1.8: the thresholds r_i must increase`` rather
    than naming 0-based JSON indices. Everything else is left to the model's own checks.

    Raises
    ------
    ParameterError
        Naming the first broken rule.
    """
    _check_node(doc, "", 0)


def _check_node(node: Any, title: str, depth: int) -> None:
    cls = _node_class(node, depth)
    if cls is None:
        return
    for field in cls.fields:
        value = node.get(field.name)
        if value is None:
            continue
        if field.kind == "model":
            _check_node(value, _join(title, _part_title(field)), depth + 1)
        elif field.kind == "models" and isinstance(value, list):
            for i, sub in enumerate(value):
                _check_node(sub, _join(title, f"stage {i + 1}"), depth + 1)
        elif field.numeric:
            _check_field(node, field, title)


def _check_field(node: Mapping[str, Any], field: Field, title: str) -> None:
    elems = _elements(node.get(field.name), field.kind)
    origin = _index_origin(node, field)
    where = f"{title}: " if title else ""
    what = f" ({(field.title or field.name).lower()})"
    prev: tuple[str, float] | None = None
    for idx, v in elems:
        ctl = field.control_at(idx[0] if idx else 0)
        if ctl is None:
            continue
        label = _label(ctl, idx, origin, field.index_base)
        if ctl.lower is not None and (v < ctl.lower or (ctl.strict and v <= ctl.lower)):
            raise ParameterError(f"{where}{label} = {_fmt(v)} must be "
                                 f"{'>' if ctl.strict else '>='} {_fmt(ctl.lower)}{what}")
        if ctl.upper is not None and (v > ctl.upper or (ctl.strict and v >= ctl.upper)):
            raise ParameterError(f"{where}{label} = {_fmt(v)} must be "
                                 f"{'<' if ctl.strict else '<='} {_fmt(ctl.upper)}{what}")
        if field.increasing and field.kind == "numbers":
            if prev is not None and v <= prev[1]:
                raise ParameterError(
                    f"{where}{prev[0]} = {_fmt(prev[1])} must stay below {label} = {_fmt(v)}: "
                    f"the {(field.title or field.name).lower()} must be increasing")
            prev = (label, v)
