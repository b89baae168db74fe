"""Internal names in words: the one place where a model type, a fit kind, a model class, a
diagnosis effect or a model field becomes what a person reads, for both interfaces.

Every name comes from what the registry declares: a model type's words are the first line
of its class docstring without the equation, the paper reference or the class references
(``gpi-deadzone`` -> "Dead-zone GPI", ``pi`` -> "Classical PI model"); a field's words are
its declared title (``Field.title``), else its control's label. :func:`in_words` rewrites
the internal names inside a sentence written elsewhere (a progress message, a diagnosis
text), and :func:`internal_names` is what a test looks for in every rendered view.
"""

from __future__ import annotations

import re
from functools import lru_cache
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from collections.abc import Iterable

    from core.models import ModelType

__all__ = ["diagnosed_words", "field_words", "in_words", "internal_names", "model_words",
           "type_words", "unit_words"]

#: Unit spellings of CSV headers -> as people write them.
UNIT_TEXT = {"um": "µm", "us": "µs", "uV": "µV", "uA": "µA", "degC": "°C", "Ohm": "Ω",
             "ohm": "Ω"}

_CLASS_REF = re.compile(r":class:`~?(?:[\w]+\.)*(\w+)`")


def unit_words(unit: str | None) -> str:
    """A unit as people write it (``um`` -> ``µm``); ``""`` for none."""
    u = unit or ""
    return UNIT_TEXT.get(u, u)


def _lower_first(text: str) -> str:
    """``"Classical PI model"`` -> ``"classical PI model"`` (an acronym stays)."""
    return text if text[1:2].isupper() else text[:1].lower() + text[1:]


def model_types() -> list[ModelType]:
    """The registry's model types (imported when first asked: a command that never shows
    a model does not import every model module)."""
    from core.models import model_types as types

    return types()


def _short(title: str, depth: int = 0) -> str:
    by_class = {t.cls.__name__: t for t in model_types()}

    def ref(m: re.Match[str]) -> str:
        t = by_class.get(m.group(1))
        if t is None or depth > 1:
            return "model"
        return _short(t.title, depth + 1)  # as written: "a Preisach model"

    text = _CLASS_REF.sub(ref, title)
    text = re.split(r"\s*``|:\s", text, maxsplit=1)[0]
    text = re.sub(r"\s*\([^()]*\)", "", text)
    text = re.split(r",\s|\.\s|\.$|;", text, maxsplit=1)[0]
    text = re.sub(r"\s+", " ", text).strip().rstrip(".:,")
    text = re.sub(r"\b([Aa])n? (?=(\w))", lambda m: m.group(1) + (
        "n " if m.group(2)[:1].lower() in "aeiou" else " "), text)
    return text[:1].upper() + text[1:]


def _type_table() -> dict[str, str]:
    from core.base import registered_types

    return _table(len(registered_types()))  # a type registered later is a new table


@lru_cache(maxsize=4)
def _table(n_types: int) -> dict[str, str]:
    table: dict[str, str] = {}
    for t in model_types():
        words = _short(t.title) or t.name.replace("-", " ").replace("_", " ")
        table[t.name] = words
        table[t.cls.__name__] = words
    return table


def type_words(name: object) -> str:
    """The words for a model type or fit kind (``"gpi-deadzone"``) or a model class name
    (``"DeadZoneGPI"``); an unknown name with its hyphens and underscores as spaces."""
    text = str(name or "")
    return _type_table().get(text) or text.replace("-", " ").replace("_", " ")


def model_words(model: object) -> str:
    """A model in words: its type's, or a chain's stages' in order (``"Input history ...
    then Dead-zone GPI"``: "Classical PI model → First-order lag"); a wrapper as what it
    wraps with its own words ("Classical PI model with initial memory")."""
    name = getattr(model, "type_name", "")
    stages = getattr(model, "stages", None)
    if name == "chain" and stages:  # a typed chain (a GPI) has words of its own
        return " → ".join(model_words(s) for s in stages)
    inner = getattr(model, "model", None)
    if getattr(inner, "type_name", None):  # a wrapper (initial memory): what it wraps, then it
        return f"{model_words(inner)} with {_lower_first(type_words(name))}"
    return type_words(name)


def diagnosed_words(model: object, findings: Iterable[str]) -> str:
    """A diagnosed model in the words of its findings (``findings``: the effects' names):
    :func:`model_words`, without the chain's constant output offset when no finding is an
    offset (the baseline's own bias, which every fit has: issue 33, the status line read
    "... → Constant output offset", a stage the findings never named)."""
    stages = getattr(model, "stages", None)
    if getattr(model, "type_name", "") == "chain" and stages and "offset" not in set(findings):
        kept = [s for s in stages if getattr(s, "type_name", "") != "offset"]
        if kept and len(kept) < len(stages):
            return " → ".join(model_words(s) for s in kept)
    return model_words(model)


def field_words(type_name: str, field_name: str) -> str:
    """The words for field ``field_name`` of model type ``type_name``: its declared title,
    else its control's label, else the name with spaces."""
    for t in model_types():
        if t.name == type_name:
            for f in t.fields:
                if f.name == field_name:
                    if f.title:
                        return f.title
                    if f.control is not None and "{" not in f.control.label:
                        return f.control.label
    return field_name.replace("_", " ")


def internal_names() -> tuple[str, ...]:
    """The names of the code a person should never read: every model class name, the type
    names that are not plain words (with a hyphen, an underscore or a digit, three letters
    or fewer, or not a word of their own type's title: ``gpi-deadzone``, ``pi``, ``chain``)
    and the field names with an underscore or a digit (``delay_s``, ``state0``)."""
    return _internal(len(_type_table()))


@lru_cache(maxsize=4)
def _internal(n_names: int) -> tuple[str, ...]:
    names: set[str] = set()
    # a type name that is also the words of a type ("tanh-envelope GPI") is a word
    said = " | ".join(_lower_first(w) for w in _type_table().values())
    for t in model_types():
        if len(re.findall(r"[A-Z]", t.cls.__name__)) >= 2:  # PIModel, not Lag
            names.add(t.cls.__name__)
        n = t.name
        if t.title.startswith(f"{n.capitalize()} model"):  # a name: preisach, not Preisach
            names.add(n)
        elif re.search(rf"(?<![\w-]){re.escape(n)}(?![\w-])", said):
            pass
        elif re.search(r"[-_\d]", n) or (len(n) <= 3 and not re.search(rf"\b{n}\b", t.title)):
            names.add(n)
        for f in t.fields:
            label = f.control.label if f.control is not None else ""
            if re.search(r"[_\d]", f.name) and f.name != label and f.name not in f.title:
                names.add(f.name)
    return tuple(sorted(names, key=lambda s: (-len(s), s)))


@lru_cache(maxsize=4)
def _pattern(names: tuple[str, ...]) -> re.Pattern[str]:
    alt = "|".join(re.escape(n) for n in names)
    return re.compile(rf"(?<![\w\-.])({alt})(?![\w\-])")


def _type_pattern() -> re.Pattern[str]:
    return _pattern(tuple(sorted(_type_table(), key=lambda s: (-len(s), s))))


def in_words(text: str) -> str:
    """``text`` with every model type, fit kind or class name in it put in words
    (``"fitting initial-memory"`` -> ``"fitting initial memory"``, ``"preisach 0.21 %"``
    -> ``"Preisach model 0.21 %"``). Plain words that are also type names (delay, lag,
    creep, drift, offset) are left as they are."""
    table, internal = _type_table(), set(internal_names())

    def sub(m: re.Match[str]) -> str:
        name = m.group(1)
        if name not in internal:
            return name
        words = table[name]
        if words.endswith(" model") and m.string[m.end():].startswith(" model"):
            words = words[:-len(" model")]
        if len(words.split()) > 5:  # a sentence, not a name: the name with spaces
            return name.replace("-", " ").replace("_", " ").replace("preisach", "Preisach")
        return words if _starts_sentence(m.string, m.start()) else _mid_sentence(words)

    return _type_pattern().sub(sub, text)


#: First words of type titles that keep their capital inside a sentence (a person's name,
#: an abbreviation).
_PROPER = ("Preisach", "Kuhnen", "Bouc", "Prandtl", "PI", "GPI", "LTI")


def _starts_sentence(text: str, at: int) -> bool:
    """Whether a name at ``at`` keeps its title's capital: it does unless a word runs on
    into it ("fitting initial-memory"; a list's item after a comma keeps it)."""
    before = text[:at].rstrip(" ")
    return not (before and before[-1].isalpha())


def _mid_sentence(words: str) -> str:
    """A title's words inside a sentence: "Initial memory" -> "initial memory"; a name
    ("Preisach model", "Kuhnen's modified PI") or an abbreviation keeps its capitals."""
    first = words.split(" ", 1)[0]
    if first.startswith(_PROPER) or first[1:2].isupper():
        return words
    return words[:1].lower() + words[1:]
