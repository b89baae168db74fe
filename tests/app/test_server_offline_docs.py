"""The API reference is served offline: no page of the server loads scripts from a CDN."""

from __future__ import annotations

import re

from fastapi.testclient import TestClient

from app.server import create_app
from app.services.settings import Settings


def test_docs_redirect_to_offline_reference_without_cdn() -> None:
    with TestClient(create_app(Settings(viser_port=0))) as c:
        r = c.get("/docs", follow_redirects=False)
        assert r.status_code in (302, 307) and r.headers["location"] == "/api.html"
        assert c.get("/redoc").status_code == 404
        for path in ("/api.html", "/"):
            page = c.get(path)
            assert page.status_code == 200
            remote = re.findall(r'<(?:script|link)[^>]+(?:src|href)="https?://[^"]+"', page.text)
            assert remote == [], f"{path} loads {remote}"
        assert c.get("/openapi.json").json()["info"]["title"] == "Hysteresis Explorer"
