"""Stateless simulation: model + signal in, properties and figures out."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, Request

from app.services.explore.config import Config
from app.services.session import actions

from .deps import SettingsDep
from .killable import run_figures
from .schemas import SimulateIn, SimulateOut

__all__ = ["router"]

router = APIRouter(prefix="/api", tags=["simulate"])


@router.post("/simulate", response_model=SimulateOut, response_model_exclude_none=True)
async def simulate(body: SimulateIn, request: Request, settings: SettingsDep) -> dict[str, Any]:
    """Simulate a model on a signal and return the requested figures.

    Out-of-range parameters (bad thresholds, too many operators or samples) give 422 with
    a message naming the parameter; only what the requested figures show is computed. The
    cost is checked here, before any work; heavy work runs in a worker process that stops
    when the client hangs up (:mod:`.killable`).
    """
    cfg = Config(model=body.model, signal=body.signal.to_spec(), mismatch=body.mismatch)
    run = actions.simulate_run(cfg, body.figures, settings, body.include_data)
    return await run_figures(request, run)
