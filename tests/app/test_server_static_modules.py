"""The page's ES modules (static/*.js): every import names a file the server serves, as
JavaScript (a module script with another type is refused under ``nosniff``), the import
graph has no cycle, and the state has one owner (static/store.js)."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.server import STATIC_DIR, create_app
from app.services.settings import Settings

IMPORT = re.compile(r'^\s*import\s[^;]*?\sfrom\s+"(/[^"]+)";', re.M | re.S)
ENTRIES = ("app.js", "lesson.js")


def _imports(name: str) -> list[str]:
    return [p.lstrip("/") for p in IMPORT.findall((STATIC_DIR / name).read_text())]


def _graph() -> dict[str, list[str]]:
    graph: dict[str, list[str]] = {}
    todo = list(ENTRIES)
    while todo:
        name = todo.pop()
        if name in graph:
            continue
        graph[name] = _imports(name)
        todo.extend(graph[name])
    return graph


@pytest.fixture(scope="module")
def client() -> Iterator[TestClient]:
    with TestClient(create_app(Settings(viser_port=0))) as c:
        yield c


def test_the_page_loads_its_entries_as_modules() -> None:
    html = (STATIC_DIR / "index.html").read_text()
    for entry in ENTRIES:
        assert f'<script type="module" src="/{entry}"></script>' in html
    # the modules are fetched at once (modulepreload), not one import level at a time
    preloaded = set(re.findall(r'<link rel="modulepreload" href="/([^"]+)">', html))
    assert preloaded == set(_graph()) - set(ENTRIES)


def test_every_import_is_served_as_javascript(client: TestClient) -> None:
    graph = _graph()
    assert len(graph) > 10  # app.js is split by what the modules hold
    for name in graph:
        r = client.get(f"/{name}")
        assert r.status_code == 200, name
        assert r.headers["content-type"].split(";")[0] == "text/javascript", name
        assert r.headers["x-content-type-options"] == "nosniff"


def test_the_import_graph_has_no_cycle() -> None:
    graph = _graph()
    done: set[str] = set()

    def visit(name: str, path: tuple[str, ...]) -> None:
        assert name not in path, " -> ".join((*path, name))
        if name in done:
            return
        for dep in graph[name]:
            visit(dep, (*path, name))
        done.add(name)

    for entry in ENTRIES:
        visit(entry, ())


def test_the_state_has_one_owner() -> None:
    """``state`` is declared in store.js only; every other module imports it from there."""
    declared = [p.name for p in Path(STATIC_DIR).glob("*.js")
                if re.search(r"^(export )?(const|let|var) state\b", p.read_text(), re.M)]
    assert declared == ["store.js"]
    for name in _graph():
        text = (STATIC_DIR / name).read_text()
        if name != "store.js" and re.search(r"\bstate\.", text):
            assert 'import { state } from "/store.js";' in text, name
        assert "window.state" not in text and "globalThis" not in text, name
