"""Stateless simulation: model + signal in, properties and figures out."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter

from ..services import actions
from ..services.config import Config
from .deps import SettingsDep
from .schemas import SimulateIn, SimulateOut

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["simulate"])


@router.post("/simulate", response_model=SimulateOut, response_model_exclude_none=True)
def simulate(body: SimulateIn, settings: SettingsDep) -> dict[str, Any]:
    """Simulate a model on a signal and return the requested figures.

    Out-of-range parameters (bad thresholds, too many operators or samples) give 422 with
    a message naming the parameter; only what the requested figures show is computed.
    """
    cfg = Config(model=body.model, signal=body.signal.to_spec(), mismatch=body.mismatch)
    return actions.simulate(cfg, body.figures, settings, body.include_data)
