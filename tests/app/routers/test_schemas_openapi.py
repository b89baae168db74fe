"""Every JSON route of the REST API declares its response model, so ``/openapi.json``
describes the response (the other routes name their media types: downloads, events, HTML)."""

from __future__ import annotations

from app.server import create_app
from app.services.settings import Settings


def test_every_route_describes_its_response() -> None:
    spec = create_app(Settings(viser_port=None)).openapi()
    schemas = spec["components"]["schemas"]
    ops = [(m, p, op) for p, item in spec["paths"].items() for m, op in item.items()]
    assert len(ops) == 37
    for method, path, op in ops:
        ok = next(code for code in op["responses"] if code.startswith("2"))
        content = op["responses"][ok]["content"]
        schema = content.get("application/json", {}).get("schema")
        if not schema:  # a download, the event stream or the HTML report: its media types
            assert set(content) - {"application/json"}, (method, path, content)
            continue
        ref = schema.get("$ref") or schema.get("items", {}).get("$ref")
        assert ref, f"{method.upper()} {path} has no response model: {schema}"
        assert schemas[ref.rsplit("/", 1)[-1]]["properties"], (method, path)


def test_session_response_documents_its_fields() -> None:
    spec = create_app(Settings(viser_port=None)).openapi()
    op = spec["paths"]["/api/sessions/{code}"]["get"]
    ref = op["responses"]["200"]["content"]["application/json"]["schema"]["$ref"]
    props = spec["components"]["schemas"][ref.rsplit("/", 1)[-1]]["properties"]
    assert list(props) == ["code", "version", "config", "recording", "fitted", "has_diagnosis"]
