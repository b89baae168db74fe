"""The model registry: the one module that imports every model module.

Each model class declares itself once: ``@register_model`` with its ``type_name`` and its JSON
``fields`` (:class:`core.base.Field`). Everything else derives from that declaration: loading
(``model_from_dict``), the parameter-set validation with JSON-path errors
(:mod:`core.paramset`), the C emitters (looked up by type in :mod:`core.export_c`), the MAT
export and the explorer's controls (:func:`model_types`).

A new model module is added to the import list below (and nowhere else).
"""

from __future__ import annotations

from dataclasses import dataclass

# every module that defines @register_model types, imported for its registrations
from . import deadzone, digitized, digitized_deadzone, effects, gpi, lti, pi  # noqa: F401
from .base import Field, Model, model_class, registered_types

__all__ = ["ModelType", "model_type", "model_types"]


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
    """

    name: str
    cls: type[Model]
    title: str
    fields: tuple[Field, ...]
    needs_dt: bool
    c_export: bool


def model_type(name: str) -> ModelType:
    """The declaration of model type ``name`` (``ParameterError`` if unknown)."""
    from .export_c import supported_c_types

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
    )


def model_types() -> list[ModelType]:
    """Every registered model type, sorted by name."""
    return [model_type(n) for n in registered_types()]
