"""Real-browser fixtures: Debian chromium through Playwright, the explorer in a thread."""

from __future__ import annotations

import os
import shutil
import tempfile
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
#: Where browser tests write screenshots: a temporary folder, so a test run never changes
#: tracked files (``python -m tests.e2e.refresh_screenshots`` refreshes docs/pages/screenshots).
SCREENSHOTS = Path(os.environ.get("HYST_SCREENSHOTS") or Path(tempfile.gettempdir())
                   / "hyst-e2e-screenshots")
#: The strict policy the static page must work under.
CSP = "default-src 'self'"
#: Teacher token of the test server.
TEACHER_TOKEN = "class-7b"
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-dev-shm-usage",
]


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    here = Path(__file__).resolve().parent
    for item in items:
        if Path(str(item.fspath)).resolve().parent == here:
            item.add_marker(pytest.mark.e2e)


@pytest.fixture(scope="session")
def browser() -> Iterator[Any]:
    if CHROMIUM is None:
        pytest.skip("chromium not installed (bash .ci/setup installs it)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:  # pragma: no cover
        pytest.skip("playwright not installed")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=ARGS, headless=True)
        yield b
        b.close()


@pytest.fixture(scope="session")
def live_server() -> Iterator[dict[str, Any]]:
    """The explorer (REST + static page + viser on a free port) served by uvicorn.

    Every response carries ``Content-Security-Policy: default-src 'self'`` (plus the
    websocket of the viser port), so a page that needs inline script, inline style
    elements, ``eval`` or an outside host fails the tests.
    """
    if CHROMIUM is None:
        pytest.skip("chromium not installed")
    import uvicorn

    from app.server import create_app
    from app.services.settings import Settings

    app = create_app(Settings(viser_port=0, port=0, teacher_token=TEACHER_TOKEN))

    @app.middleware("http")
    async def _csp(request: Any, call_next: Any) -> Any:
        response = await call_next(request)
        if "content-security-policy" not in response.headers:
            response.headers["Content-Security-Policy"] = CSP
        return response

    config = uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning")
    server = uvicorn.Server(config)
    th = threading.Thread(target=server.run, daemon=True)
    th.start()
    deadline = time.monotonic() + 30
    while not server.started:
        if time.monotonic() > deadline or not th.is_alive():
            raise RuntimeError("explorer did not start")
        time.sleep(0.05)
    port = server.servers[0].sockets[0].getsockname()[1]
    yield {
        "url": f"http://127.0.0.1:{port}/",
        "viser_url": f"http://127.0.0.1:{app.state.viser_port}/",
        "app": app,
    }
    server.should_exit = True
    th.join(timeout=10)


@pytest.fixture
def shot() -> Any:
    """``shot(page, name)`` saves ``<SCREENSHOTS>/<name>.png`` (a temporary folder)."""
    SCREENSHOTS.mkdir(parents=True, exist_ok=True)

    def save(page: Any, name: str) -> Path:
        path = SCREENSHOTS / f"{name}.png"
        page.screenshot(path=str(path))
        return path

    return save


@pytest.fixture()
def slow_diagnosis(monkeypatch: pytest.MonkeyPatch) -> None:
    """The diagnosis pauses 0.5 s at each progress report, so that it is still running when
    the page reacts (a Cancel or a reload); otherwise a fast machine finishes the piezo
    diagnosis before the click and the test measures the race, not the page. (A job runs in
    a worker process: the server sends it the work function by name, so the slow one is a
    module-level function of the tests.)"""
    from app.services.jobs import tasks
    from tests.app.job_work import slow_diagnosis as slow

    monkeypatch.setattr(tasks, "run_diagnosis", slow)
