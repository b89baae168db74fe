"""The C emitters of :func:`core.export_c.generate_c`, one module per model family.

Each module registers the emitters of its model classes with
:func:`core.c_emit.stage.register_c_stage`; :func:`core.c_emit.stage.emitter_for` finds a
model's emitter by its class (or its nearest registered base class). A new model family is
one module here, ``@register_c_stage(TheClass)`` on a function ``(model, ctx) -> CStage``,
and its import below.
"""

from . import (
    boucwen,
    digitized,
    dynamics,
    gpi,
    lti,
    nonmasing,
    pi,
    preisach,
    rate,
    static,
    stop,
)

__all__ = ["boucwen", "digitized", "dynamics", "gpi", "lti", "nonmasing", "pi", "preisach",
           "rate", "static", "stop"]
