"""The model registry: the one module that imports every model module.

Each model class declares itself once: ``@register_model`` with its ``type_name`` and its JSON
``fields`` (:class:`core.base.Field`). Everything else derives from that declaration: loading
(``model_from_dict``), the parameter-set validation with JSON-path errors
(:mod:`core.paramset`), the C emitters (looked up by type in :mod:`core.export_c`), the MAT
export, the explorer's controls (:func:`model_types`) and the fit kinds of ``hyst fit
--model``, ``hyst batch fit`` and the explorer's fit menu (:func:`fit_kinds`: the types that
declare an ``estimator``).

A new model module is added to the import list below (and nowhere else).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass

# every module that defines @register_model types, imported for its registrations
from . import (  # noqa: F401
    boucwen,
    deadzone,
    digitized,
    digitized_deadzone,
    gpi,
    lti,
    nonmasing,
    pi,
    preisach,
    stages,
    stop,
)
from .base import Field, Model, model_class, registered_types
from .exceptions import ParameterError
from .export_c import supported_c_types

__all__ = ["DEFAULT_FIT_KIND", "ModelType", "estimator_class", "fit_kinds", "model_type",
           "model_types"]

#: The fit kind used when none is chosen (listed first by :func:`fit_kinds`).
DEFAULT_FIT_KIND = "pi"


@dataclass(frozen=True)
class ModelType:
    """What a registered model type declares about itself.

    Attributes
    ----------
    name : str
        The ``type`` of its JSON form.
    cls : type
        The :class:`~core.base.Model` subclass.
    title : str
        First line of the class docstring.
    fields : tuple of Field
        Its JSON fields (name, kind, optional, units in ``doc``): what an editor shows.
    needs_dt : bool
        Whether it has dynamics (needs the sample spacing).
    c_export : bool
        Whether :func:`core.export_c.generate_c` can emit it (directly or through
        ``as_chain()``).
    estimator : str or None
        ``"module:Class"`` of the estimator that fits it (the class's own ``estimator``
        declaration, not inherited); ``None`` if it is not a fit kind.
    """

    name: str
    cls: type[Model]
    title: str
    fields: tuple[Field, ...]
    needs_dt: bool
    c_export: bool
    estimator: str | None = None


def model_type(name: str) -> ModelType:
    """The declaration of model type ``name`` (``ParameterError`` if unknown)."""
    cls = model_class(name)
    needs_dt = cls.__dict__.get("needs_dt", getattr(cls, "needs_dt", False))
    return ModelType(
        name=name,
        cls=cls,
        title=(cls.__doc__ or name).strip().splitlines()[0],
        fields=cls.fields,
        needs_dt=needs_dt if isinstance(needs_dt, bool) else False,
        c_export=name in supported_c_types() or callable(getattr(cls, "as_chain", None))
        or name == "chain",
        estimator=cls.__dict__.get("estimator"),
    )


def model_types() -> list[ModelType]:
    """Every registered model type, sorted by name."""
    return [model_type(n) for n in registered_types()]


def fit_kinds() -> tuple[str, ...]:
    """Names of the model types that declare an estimator: :data:`DEFAULT_FIT_KIND` first,
    the others by name (the choices of ``hyst fit --model`` and the explorer's fit menu)."""
    kinds = [t.name for t in model_types() if t.estimator]
    return tuple(sorted(kinds, key=lambda k: (k != DEFAULT_FIT_KIND, k)))


def estimator_class(kind: str) -> type:
    """The estimator class declared by fit kind ``kind`` (see :func:`fit_kinds`).

    Raises
    ------
    ParameterError
        If ``kind`` is not a fit kind; the message lists those there are.
    """
    kinds = fit_kinds()
    if kind not in kinds:
        raise ParameterError(f"fit kind {kind!r} is not available; use one of "
                             f"{', '.join(kinds)}")
    module, _, name = str(model_type(kind).estimator).partition(":")
    return getattr(importlib.import_module(module), name)
