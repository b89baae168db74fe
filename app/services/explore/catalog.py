"""What the explorer offers: model types, signals, presets, fit kinds, figures, formats.

The routers' ``GET /api/capabilities`` and ``GET /api/presets`` and the viser GUI's menus
read these lists here, so neither interface looks into :mod:`core` for them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypedDict

from app.services.explore.simulation import PresetDoc, preset_doc
from app.services.words import type_words
from core.base import registered_types
from core.models import fit_kinds
from core.presets import list_presets
from core.signals import SIGNALS

if TYPE_CHECKING:
    from app.services.settings import Settings

__all__ = ["EXPORT_FORMATS", "Capabilities", "capabilities", "fit_kinds", "preset_doc",
           "preset_names", "preset_titles", "presets", "signal_kinds"]


#: Download formats of a parameter set (:func:`app.services.session.exports.export_bytes`).
EXPORT_FORMATS = ("json", "mat", "c", "fmu")


def signal_kinds() -> tuple[str, ...]:
    """Names of the input signals (:data:`core.signals.SIGNALS`), in their order."""
    return tuple(SIGNALS)


def preset_names() -> list[str]:
    """Names of the presets, in their order."""
    return [p.name for p in list_presets()]


def preset_titles() -> dict[str, str]:
    """``{title: name}`` of every preset, in their order (the GUI's preset menu)."""
    return {p.title: p.name for p in list_presets()}


class Capabilities(TypedDict):
    """What the server offers (:func:`capabilities`, ``GET /api/capabilities``)."""

    model_types: list[str]
    signals: list[str]
    presets: list[str]
    figures: list[str]
    export_formats: list[str]
    fit_kinds: list[str]
    #: each fit kind in words (the menus show these)
    fit_kind_titles: dict[str, str]
    #: the upload's size limit and :class:`~app.services.explore.cost.Limits`, by name
    limits: dict[str, float]


def presets() -> list[PresetDoc]:
    """Every preset's :func:`~app.services.explore.simulation.preset_doc`."""
    return [preset_doc(name) for name in preset_names()]


def capabilities(settings: Settings) -> Capabilities:
    """Model types, signals, presets, figures, export formats, fit kinds and limits."""
    from app.services.explore.figures import FIGURES

    return {
        "model_types": registered_types(),
        "signals": list(SIGNALS),
        "presets": preset_names(),
        "figures": list(FIGURES),
        "export_formats": list(EXPORT_FORMATS),
        "fit_kinds": list(fit_kinds()),
        "fit_kind_titles": {k: type_words(k) for k in fit_kinds()},
        "limits": {"max_upload_bytes": settings.max_upload_bytes,
                   **settings.limits.to_dict()},
    }
