"""The sliders of a model, derived from the model types' field declarations."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from app.services.session import actions

from .deps import SettingsDep
from .schemas import ClampIn, ClampOut, ControlsIn, ControlsOut, controls_json

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["simulate"])


@router.post("/controls", response_model=ControlsOut)
def controls(body: ControlsIn, settings: SettingsDep) -> dict[str, Any]:
    """The sliders of a model document: label, unit, range, step, hard limits and
    neighbours of each number, grouped by field.

    Both the web page and the viser GUI build their parameter sliders from this
    description, so every registered model type has sliders. An invalid model gives 422
    naming the broken rule in the labels the sliders show (``r3 = 3.3 must stay below
    r4 = 1.8``).
    """
    return controls_json(actions.checked_controls(body.model, settings))


@router.post("/controls/clamp", response_model=ClampOut)
def clamp(body: ClampIn, settings: SettingsDep) -> dict[str, Any]:
    """A slider's move kept inside its field's rules: whole numbers, hard limits, one step
    short of an increasing neighbour (``r3`` stops just below ``r4``), and a note saying
    what a rule changed in the labels the sliders show (``""`` when nothing did).

    The web page asks for every move, the viser GUI calls the same service: the rules live
    once, in ``app/services/explore/controls.py``.
    """
    done = actions.clamp_slider(body.model, body.path, body.value, settings)
    return {"value": done.value, "note": done.note}
