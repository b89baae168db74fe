"""``hyst serve``: the explorer (REST API + static page + viser GUI) in one process."""

from __future__ import annotations

import argparse
import threading
import time
import webbrowser
from typing import Any

__all__ = ["register", "run"]


def register(subparsers: Any) -> None:
    """Add the ``serve`` sub-command."""
    p = subparsers.add_parser(
        "serve",
        help="start the browser explorer (REST API, web page and viser GUI)",
        description=(
            "Start the Hysteresis Explorer: a FastAPI server (REST API with an offline "
            "reference at /api.html, and a plain web page at /) and a viser GUI on a second "
            "port, in one process. Binds "
            "127.0.0.1 by default; use --host 0.0.0.0 to let a class on the same network in."
        ),
    )
    p.add_argument("--host", default=None,
                   help="interface to bind (default 127.0.0.1; env HYST_HOST)")
    p.add_argument("--port", type=int, default=None,
                   help="HTTP port (default 8000; env HYST_PORT; 0 = any free port)")
    p.add_argument("--viser-port", type=int, default=None,
                   help="viser GUI port (default 8080, the next free one if busy; "
                        "env HYST_VISER_PORT; 0 = any free port)")
    p.add_argument("--no-viser", action="store_true", help="REST API and web page only")
    p.add_argument("--no-browser", action="store_true", help="do not open a browser")
    p.add_argument("--teacher-token", default=None,
                   help="require this X-Teacher-Token header to push presets to all sessions")
    p.set_defaults(func=run)


def _announce(server: Any, app: Any, host: str, open_browser: bool) -> None:
    while not server.started and not server.should_exit:
        time.sleep(0.05)
    if not server.started:
        return
    shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    port = server.servers[0].sockets[0].getsockname()[1]
    web = f"http://{shown}:{port}/"
    print(f"Hysteresis Explorer web page: {web}   (API reference: {web}api.html)", flush=True)
    vport = getattr(app.state, "viser_port", None)
    gui = f"http://{shown}:{vport}/" if vport else None
    if gui:
        print(f"Hysteresis Explorer GUI (viser): {gui}", flush=True)
    if host in ("0.0.0.0", "::"):
        print("Listening on every interface: students use this machine's address.", flush=True)
    print("Press Ctrl+C to stop.", flush=True)
    if open_browser:
        webbrowser.open(gui or web)


def run(args: argparse.Namespace) -> int:
    """Start both servers and block until Ctrl+C."""
    import uvicorn

    from ..server import create_app
    from ..settings import Settings

    settings = Settings.from_env(
        host=args.host,
        port=args.port,
        viser_port=args.viser_port,
        teacher_token=args.teacher_token,
    )
    if args.no_viser:
        settings = Settings(**{**settings.__dict__, "viser_port": None})
    app = create_app(settings)
    config = uvicorn.Config(app, host=settings.host, port=settings.port, log_level="warning")
    server = uvicorn.Server(config)
    threading.Thread(target=_announce, args=(server, app, settings.host, not args.no_browser),
                     daemon=True).start()
    server.run()
    return 0
