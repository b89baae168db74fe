"""Pydantic request/response models of the REST API (the only module using pydantic)."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

from ..services.config import Config, SignalSpec

__all__ = [
    "ConfigIn",
    "FigureOut",
    "FitIn",
    "SignalIn",
    "SimulateIn",
    "SimulateOut",
]


class SignalIn(BaseModel):
    """Input signal ``offset + amplitude * shape(frequency t)`` on ``[0, duration]``."""

    model_config = ConfigDict(extra="forbid")
    kind: str = Field("sine", description="signal name, see GET /api/capabilities")
    amplitude: float = Field(4.0, ge=-1e6, le=1e6, description="input units")
    frequency: float = Field(1.0, ge=0, le=1e5, description="Hz")
    offset: float = Field(0.0, ge=-1e6, le=1e6, description="input units")
    duration: float = Field(2.0, gt=0, le=3600, description="s")
    samples: int = Field(2000, ge=2, description="number of samples (limit: max_samples)")

    def to_spec(self) -> SignalSpec:
        """The core-side value object."""
        return SignalSpec(**self.model_dump())


class ConfigIn(BaseModel):
    """Partial update of a session's config (omitted fields keep their value)."""

    model_config = ConfigDict(extra="forbid")
    model: dict[str, Any] | None = Field(
        None, description="a model document with a 'type' field, e.g. {'type': 'pi', ...}"
    )
    signal: SignalIn | None = None
    mismatch: float | None = Field(None, ge=-0.9, le=0.9, description="plant perturbation")
    use_recording: bool | None = None

    def apply(self, cfg: Config) -> Config:
        """``cfg`` with the given fields replaced."""
        from dataclasses import replace

        kw: dict[str, Any] = {}
        if self.model is not None:
            kw["model"] = dict(self.model)
        if self.signal is not None:
            kw["signal"] = self.signal.to_spec()
        if self.mismatch is not None:
            kw["mismatch"] = float(self.mismatch)
        if self.use_recording is not None:
            kw["use_recording"] = self.use_recording
        return replace(cfg, **kw)


class SimulateIn(BaseModel):
    """Stateless simulation request."""

    model_config = ConfigDict(extra="forbid")
    model: dict[str, Any] = Field(..., description="model document with a 'type' field")
    signal: SignalIn = Field(default_factory=SignalIn)
    mismatch: float = Field(0.0, ge=-0.9, le=0.9)
    figures: list[str] = Field(
        default_factory=lambda: ["loop"],
        description="figures to build: time, loop, operators, loading, inverse",
    )
    include_data: bool = Field(False, description="also return t, u, y arrays")


class FigureOut(BaseModel):
    """A plotly figure (hand it to Plotly.react)."""

    data: list[dict[str, Any]]
    layout: dict[str, Any]


class SimulateOut(BaseModel):
    """Simulation result: model properties, figures and optionally the raw signals."""

    model_type: str
    n_operators: int | None = None
    slopes: list[float] | None = None
    max_loop_width: float | None = None
    invertible: bool | None = None
    inverse_error: str | None = None
    figures: dict[str, FigureOut] = Field(default_factory=dict)
    data: dict[str, list[float]] | None = None
    elapsed_ms: float


class FitIn(BaseModel):
    """Fit request on the session's uploaded recording."""

    model_config = ConfigDict(extra="forbid")
    kind: str = Field("pi", description="model kind to fit, see GET /api/capabilities")
    n: int = Field(10, ge=1, description="number of play operators (limit: max_operators)")
    apply: bool = Field(True, description="make the fitted model the session's model")
