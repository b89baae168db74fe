"""Stateless simulation: model + signal in, properties and figures out."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException

from .. import figures as F
from ..compute import Result, compute, operator_count, pi_part
from ..schemas import SimulateIn, SimulateOut
from ..services.cost import check_config
from ..state import Config
from .deps import SettingsDep

__all__ = ["result_payload", "router"]

router = APIRouter(prefix="/api", tags=["simulate"])


def result_payload(
    res: Result, names: list[str], mismatch: float, include_data: bool
) -> dict[str, Any]:
    """JSON body shared by ``/api/simulate`` and the session figure endpoints."""
    unknown = [n for n in names if n not in F.FIGURES]
    if unknown:
        raise HTTPException(422, f"unknown figure(s) {unknown}; known: {list(F.FIGURES)}")
    m = res.model
    out: dict[str, Any] = {
        "model_type": m.type_name,
        "n_operators": operator_count(m),
        "inverse_error": res.inverse_error,
        "figures": {n: F.build(n, res, mismatch).to_dict() for n in names},
        "elapsed_ms": res.elapsed_ms,
        "version": res.version,
    }
    pi = pi_part(m)
    if pi is not None:
        m = pi
        out.update(
            slopes=m.slopes.tolist(), max_loop_width=m.max_loop_width, invertible=m.is_invertible
        )
    if include_data:
        out["data"] = {"t": res.t.tolist(), "u": res.u.tolist(), "y": res.y.tolist()}
    return out


@router.post("/simulate", response_model=SimulateOut, response_model_exclude_none=True)
def simulate(body: SimulateIn, settings: SettingsDep) -> dict[str, Any]:
    """Simulate a model on a signal and return the requested figures.

    Out-of-range parameters (bad thresholds, too many operators or samples) give 422 with
    a message naming the parameter.
    """
    cfg = Config(model=body.model, signal=body.signal.to_spec(), mismatch=body.mismatch)
    check_config(cfg, None, settings.limits)  # bounded cost, checked before any work
    res = compute(cfg, max_operators=settings.max_operators, max_samples=settings.max_samples,
                  with_inverse="inverse" in body.figures,
                  with_digitized="digitized" in body.figures)
    return result_payload(res, body.figures, body.mismatch, body.include_data)
