"""``hyst serve``: the explorer (REST API + static page + viser GUI) in one process."""

from __future__ import annotations

import argparse
import copy
import gc
import os
import sys
import threading
import time
import webbrowser
from pathlib import Path
from typing import Any

__all__ = ["register", "run", "settings_of"]

#: Seconds a SIGTERM/Ctrl+C waits for open requests before the process exits anyway.
SHUTDOWN_S = 3.0
#: File in the state directory that receives a generated teacher token.
TOKEN_FILE = "teacher-token"


def register(subparsers: Any) -> None:
    """Add the ``serve`` sub-command."""
    p = subparsers.add_parser(
        "serve",
        help="start the browser explorer (REST API, web page and viser GUI)",
        description=(
            "Start the Hysteresis Explorer: a FastAPI server (REST API with an offline "
            "reference at /api.html, and a plain web page at /) and a viser GUI on a second "
            "port, in one process. Binds 127.0.0.1 by default; use --host 0.0.0.0 to let a "
            "class on the same network in (a teacher token is then required to broadcast; if "
            "you give none, one is generated into a file readable by you only, in --state-dir, "
            "and the file's path is printed). Sessions are stored in SQLite under --state-dir "
            "and survive a restart. Session codes never appear in the log."
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
    p.add_argument("--teacher-token-file", default=None, type=Path,
                   help="file holding the teacher token needed to push presets to every "
                        "session (or set env HYST_TEACHER_TOKEN)")
    p.add_argument("--teacher-token", default=None,
                   help="the teacher token itself (visible to other users in `ps`: prefer "
                        "--teacher-token-file or HYST_TEACHER_TOKEN)")
    p.add_argument("--state-dir", default=None, type=Path,
                   help="directory of the session database (default: the per-user data "
                        "directory, ~/.local/share/hysteresis-explorer; env HYST_STATE_DIR)")
    p.add_argument("--max-store-mb", type=int, default=None,
                   help="size budget of the stored sessions in MB (default 1000); beyond "
                        "it sessions unused for an hour are evicted, those of the computer "
                        "holding the most first, never a teacher's; when none may go, "
                        "a teacher opening a session makes room")
    p.add_argument("--max-client-store-mb", type=int, default=None, metavar="MB",
                   help="MB the sessions opened from one computer may hold together "
                        "(default a tenth of --max-store-mb; env HYST_MAX_CLIENT_STORE_MB); "
                        "beyond it that computer's own sessions unused for an hour go, "
                        "then its uploads are refused with a message. A teacher's "
                        "sessions are exempt")
    p.add_argument("--max-sessions-per-client", type=int, default=None, metavar="N",
                   help="sessions one computer may have opened and still kept (default "
                        "500; env HYST_MAX_SESSIONS_PER_CLIENT)")
    p.add_argument("--max-session-mb", type=int, default=None, metavar="MB",
                   help="MB one session may hold: its recording, fit and diagnosis "
                        "(default 20; env HYST_MAX_SESSION_MB)")
    p.add_argument("--worker-memory-mb", type=int, default=None, metavar="MB",
                   help="memory each fit, diagnosis or heavy-figure worker process may use "
                        "beyond its start, MB (default: twice the priced memory limit of a "
                        "request, 3000, at most a quarter of this machine's memory; env "
                        "HYST_WORKER_MEMORY_MB); a job that needs more fails with a message")
    p.add_argument("--allowed-host", action="append", default=None, metavar="NAME",
                   help="another name this server answers to, e.g. the machine's name on "
                        "the class network (repeatable; env HYST_ALLOWED_HOSTS, comma-"
                        "separated). Loopback names, the --host address and the address a "
                        "student typed are always allowed; requests naming any other host "
                        "are refused (protection against DNS rebinding)")
    p.add_argument("--trusted-proxy", action="append", default=None, metavar="ADDR",
                   help="address or network (10.0.0.0/8) of a reverse proxy in front of the "
                        "server, repeatable: only requests from it have their X-Forwarded-For "
                        "read for the per-computer limits (default none: the header is "
                        "ignored; env HYST_TRUSTED_PROXIES, comma-separated)")
    p.add_argument("--header-timeout", type=float, default=None, metavar="S",
                   help="seconds a request's headers may take to arrive (default 10; env "
                        "HYST_HEADER_TIMEOUT_S); then 408 and the connection is closed")
    p.add_argument("--body-timeout", type=float, default=None, metavar="S",
                   help="seconds a request's body may take once its headers arrived "
                        "(default 60: a 5 MB upload at 1 Mbit/s; env HYST_BODY_TIMEOUT_S)")
    p.add_argument("--max-connections-per-client", type=int, default=None, metavar="N",
                   help="open connections of one computer to the HTTP port (default 100; env "
                        "HYST_MAX_CONNECTIONS_PER_CLIENT); one more is answered 503")
    p.add_argument("--access-log", action="store_true",
                   help="print one line per request (session codes masked)")
    p.set_defaults(func=run)


def _token(args: argparse.Namespace) -> str | None:
    if args.teacher_token_file is not None:
        try:
            tok = args.teacher_token_file.read_text(encoding="utf-8").strip()
        except OSError as exc:
            raise SystemExit(f"hyst serve: cannot read --teacher-token-file: {exc}") from None
        if not tok:
            raise SystemExit(f"hyst serve: {args.teacher_token_file} is empty")
        return tok
    if args.teacher_token is not None:
        print("Note: --teacher-token is visible to other users of this machine (ps); "
              "prefer --teacher-token-file or HYST_TEACHER_TOKEN.", file=sys.stderr)
    return args.teacher_token


def _save_token(state_dir: str, token: str) -> Path:
    """Write a generated teacher token to ``teacher-token`` in ``state_dir``, readable by
    this user only (0600), and return the file's path (printed instead of the token)."""
    path = Path(state_dir) / TOKEN_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    try:
        os.fchmod(fd, 0o600)  # an older file keeps its mode on open: set it anyway
        os.write(fd, (token + "\n").encode("utf-8"))
    finally:
        os.close(fd)
    return path


def _log_config(access_log: bool) -> dict[str, Any]:
    """uvicorn's logging, with every handler masking session codes
    (:class:`~app.services.guard.redaction.RedactCodes`) and letting a repeated warning or error
    through a few times per 10 s (:class:`~app.connections.RepeatFilter`); the app's own
    loggers use it too."""
    from uvicorn.config import LOGGING_CONFIG

    cfg = copy.deepcopy(LOGGING_CONFIG)
    cfg["filters"] = {"codes": {"()": "app.services.guard.redaction.RedactCodes"},
                      "repeats": {"()": "app.connections.RepeatFilter"}}
    for handler in cfg["handlers"].values():
        handler["filters"] = ["repeats", "codes"]
    cfg["loggers"]["uvicorn.error"]["level"] = "WARNING"
    cfg["loggers"]["uvicorn.access"]["level"] = "INFO" if access_log else "WARNING"
    cfg["root"] = {"handlers": ["default"], "level": "WARNING"}
    return cfg


def _announce(server: Any, app: Any, settings: Any, token_file: Path | None,
              open_browser: bool) -> None:
    while not server.started and not server.should_exit:
        time.sleep(0.05)
    if not server.started:
        return
    host = settings.host
    shown = "127.0.0.1" if host in ("0.0.0.0", "::") else host
    port = server.servers[0].sockets[0].getsockname()[1]
    web = f"http://{shown}:{port}/"
    print(f"Hysteresis Explorer web page: {web}   (API reference: {web}api.html)", flush=True)
    vport = getattr(app.state, "viser_port", None)
    gui = f"http://{shown}:{vport}/" if vport else None
    if gui:
        print(f"Hysteresis Explorer GUI (viser): {gui}", flush=True)
    print(f"Sessions are stored in {settings.state_dir} (they survive a restart).",
          flush=True)
    if settings.public:
        print(f"WARNING: listening on {host}: every computer that can reach this one may open "
              f"the web page (port {port})" + (f" and the viser GUI (port {vport})" if vport
                                               else "") +
              ", create sessions and join one whose code it knows. Use it on a trusted "
              "class network only.", flush=True)
        if token_file is not None:
            print(f"Teacher token (needed to push presets to every session): generated into "
                  f"{token_file} (readable by you only)", flush=True)
        else:
            print("Broadcasting needs the teacher token you gave.", flush=True)
    print("Press Ctrl+C to stop.", flush=True)
    if open_browser:
        webbrowser.open(gui or web)


def settings_of(args: argparse.Namespace) -> Any:
    """The :class:`~app.services.settings.Settings` of ``hyst serve``'s arguments: the
    ``HYST_*`` environment, then the options given."""
    from app.services.settings import Settings
    from app.services.storage.store import default_state_dir

    try:
        settings = Settings.from_env(
            host=args.host,
            port=args.port,
            viser_port=args.viser_port,
            teacher_token=_token(args),
            state_dir=None if args.state_dir is None else str(args.state_dir),
            max_store_mb=args.max_store_mb,
            max_client_store_mb=args.max_client_store_mb,
            max_sessions_per_client=args.max_sessions_per_client,
            max_session_mb=args.max_session_mb,
            header_timeout_s=args.header_timeout,
            body_timeout_s=args.body_timeout,
            max_connections_per_client=args.max_connections_per_client,
            worker_memory_mb=args.worker_memory_mb,
            allowed_hosts=None if not args.allowed_host else tuple(args.allowed_host),
            trusted_proxies=None if args.trusted_proxy is None else tuple(args.trusted_proxy),
        )
    except ValueError as exc:
        raise SystemExit(f"hyst serve: {exc}") from None
    if not settings.state_dir:
        settings = Settings(**{**settings.__dict__, "state_dir": str(default_state_dir())})
    if args.no_viser:
        settings = Settings(**{**settings.__dict__, "viser_port": None})
    return settings


def run(args: argparse.Namespace) -> int:
    """Start both servers and block until Ctrl+C or SIGTERM (stops within a few seconds)."""
    import uvicorn

    from ..connections import http_protocol
    from ..server import create_app

    settings = settings_of(args)
    settings, generated = settings.with_teacher_token()
    token_file = _save_token(settings.state_dir, settings.teacher_token) if generated else None
    app = create_app(settings)
    protocol, app.state.connections, fd_message = http_protocol(settings)
    if fd_message:
        print(f"Note: {fd_message}.", file=sys.stderr, flush=True)
    # proxy_headers=False: uvicorn would take X-Forwarded-For from any loopback peer;
    # the app reads it itself, from the --trusted-proxy peers only (app.services.guard.clients)
    config = uvicorn.Config(app, host=settings.host, port=settings.port, log_level=None,
                            log_config=_log_config(args.access_log),
                            access_log=args.access_log, proxy_headers=False,
                            http=protocol, timeout_keep_alive=5,
                            timeout_graceful_shutdown=int(SHUTDOWN_S))
    server = uvicorn.Server(config)
    threading.Thread(target=_announce, args=(server, app, settings, token_file,
                                             not args.no_browser), daemon=True).start()

    def _hard_stop() -> None:  # a worker thread stuck in numerics must not keep us alive
        time.sleep(SHUTDOWN_S + 1.5)
        os._exit(0)

    uvicorn_exit = server.handle_exit

    def _on_signal(signum: int, frame: Any) -> None:
        jobs = getattr(app.state, "jobs", None)
        if jobs is not None:
            jobs.cancel_all()
        threading.Thread(target=_hard_stop, daemon=True).start()
        uvicorn_exit(signum, frame)

    server.handle_exit = _on_signal  # type: ignore[method-assign]
    # what start-up imported (numba, scipy, plotly, fastapi: ~160,000 objects) lives as long
    # as the process: frozen out of the collector's way, a full collection no longer stops
    # every request for ~0.2 s to walk it again (issue 18 item 8)
    gc.collect()
    gc.freeze()
    server.run()
    return 0
