"""Health, capabilities, the viser URL and the vendored plotly.js."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi import APIRouter, HTTPException, Request
from fastapi.responses import FileResponse

from app.services.explore import catalog

from .deps import SettingsDep
from .schemas import CapabilitiesOut, HealthOut, PresetOut, ViserUrlOut

__all__ = ["router", "vendor_router"]

router = APIRouter(prefix="/api", tags=["meta"])
vendor_router = APIRouter(tags=["meta"])


@router.get("/health", response_model=HealthOut, response_model_exclude_unset=True)
def health() -> dict[str, str]:
    """Liveness probe."""
    return {"status": "ok"}


@router.get("/viser-url", response_model=ViserUrlOut, response_model_exclude_unset=True)
def viser_url(request: Request) -> dict[str, Any]:
    """Where the viser GUI listens (its port may differ from the requested one)."""
    port = getattr(request.app.state, "viser_port", None)
    if port is None:
        return {"enabled": False, "url": None, "port": None}
    host = request.url.hostname or "127.0.0.1"
    return {"enabled": True, "url": f"http://{host}:{port}/", "port": port}


@router.get("/capabilities", response_model=CapabilitiesOut, response_model_exclude_unset=True)
def capabilities(settings: SettingsDep) -> dict[str, Any]:
    """Model types, signals, presets, figures, export formats and limits."""
    return catalog.capabilities(settings)


@router.get("/presets", response_model=list[PresetOut], response_model_exclude_unset=True)
def presets() -> list[dict[str, Any]]:
    """Every preset: name, title, description and model document."""
    return catalog.presets()


def plotly_js_path() -> Path:
    """The plotly.min.js shipped inside the installed plotly package."""
    import plotly

    return Path(plotly.__file__).parent / "package_data" / "plotly.min.js"


@vendor_router.get("/vendor/plotly.min.js", include_in_schema=False)
def plotly_js() -> FileResponse:
    """plotly.js from the plotly Python package (no CDN)."""
    path = plotly_js_path()
    if not path.exists():  # pragma: no cover - broken install
        raise HTTPException(404, "plotly.min.js not found in the plotly package")
    return FileResponse(path, media_type="text/javascript",
                        headers={"Cache-Control": "public, max-age=86400"})
