"""The viser port's guard: the REST rules on viser's own page and websocket.

viser serves its page and its websocket itself (``websockets.asyncio.server.serve`` with a
``process_request`` callback answering the page requests), not through FastAPI, so
:class:`app.security.Guard` never sees them. :func:`start_viser` starts a
``viser.ViserServer`` whose ``process_request`` is wrapped by :class:`ViserGuard`; nothing
in site-packages is edited:

* **Own names only**: a request whose ``Host`` is not a name of this server
  (:class:`app.services.guard.hosts.HostAllowList`) is a 421, page or websocket, before viser
  sees it.
* **Foreign origins**: a websocket handshake whose ``Origin`` (or ``Sec-Fetch-Site:
  cross-site``) is not this server is a 403 before the connection is accepted
  (:func:`app.services.guard.hosts.foreign_origin`), so another site's page open in a browser
  cannot drive a GUI tab; a page request carrying a foreign ``Origin`` likewise.
* **Headers**: every page response carries :data:`VISER_CSP` (``frame-ancestors 'none'``),
  ``X-Frame-Options: DENY``, ``X-Content-Type-Options: nosniff`` and ``Referrer-Policy:
  no-referrer``.
* **Client address**: each websocket's client address (:func:`app.services.guard.clients.
  client_address`, ``X-Forwarded-For`` only from ``--trusted-proxy`` peers) is kept for the
  per-client session limit (:meth:`ViserGuard.client_address`).
* **Browser**: the page sets a random browser id in the cookie :data:`BROWSER_COOKIE`
  (``HttpOnly``, ``SameSite=Strict``; not the session code); the websocket's handshake
  brings it back (:meth:`ViserGuard.browser_id`), so a reloaded tab finds its session.
* **Open tabs**: a client holding ``max_tabs_per_client`` open websockets gets a 429 for
  the next handshake, and the server a 503 beyond ``max_tabs`` in all, before the
  connection is accepted (each open tab holds a view: widgets, a render thread, its
  results; about 5-16 MB measured).
* **Message size**: a websocket message from a tab may be at most :data:`MAX_MESSAGE_BYTES`
  (viser's own limit is 50 MB) and at most :data:`MAX_QUEUED_FRAMES` frames wait unread,
  so what one connection buffers is bounded (viser's client uploads files in 512 KiB
  parts).
* **Uploads**: viser buffers an upload's parts in memory up to the size its client
  declares, with no limit of its own; an upload declaring more than ``max_upload_bytes``
  (or more parts than that size needs, or a tab's :data:`MAX_UPLOADS_PER_TAB` + 1-th at
  once) is dropped before any part is kept, and the tab told why; a part beyond the declared
  size drops its upload (:func:`bound_uploads`). The explorer's own check
  (:attr:`ViserGuard.upload_check`: the CSV button's size and first bytes, in the web page's
  words) runs on the start message and on the first part, so such a file is refused before
  any of it is kept, the button is ready for the next file and the upload's progress toast
  goes. viser's client sends every part without waiting for the server (viser 1.1 has no
  size limit on its upload button), so the parts of a refused file still cross the
  connection and are dropped as they come.

The wrap relies on viser internals (``viser.infra._infra`` calling
``websockets.asyncio.server.serve`` from ``WebsockServer.start``, its ``viser_http_server``
callback and ``_live_connections``); :func:`check_viser` refuses other viser versions and
:func:`start_viser` fails loudly when the wrap was not installed.
"""

from __future__ import annotations

import functools
import http
import re
import secrets
import threading
import weakref
from collections.abc import Callable
from typing import Any

from app.services.guard.clients import client_address
from app.services.guard.hosts import HostAllowList, foreign_origin, host_name

__all__ = ["BROWSER_COOKIE", "MAX_MESSAGE_BYTES", "MAX_QUEUED_FRAMES", "MAX_UPLOADS_PER_TAB",
           "SUPPORTED_VISER", "VISER_CSP", "ViserGuard", "ViserGuardError", "bound_uploads",
           "check_viser", "start_viser"]

#: The viser versions whose internals this module was checked against (``major.minor.``).
SUPPORTED_VISER = ("1.1.",)

#: The policy of viser's page. Its single ``index.html`` holds one inline loader script that
#: unpacks the client with a WebAssembly decoder and inserts it as an inline module script
#: (``'unsafe-inline'``, ``'wasm-unsafe-eval'``); the client evaluates the plotly.js the
#: server sends over the websocket for its plots (``'unsafe-eval'``) and fetches its
#: decoder and environment map from ``data:`` URLs (``connect-src data:``, which reaches no
#: host). Everything else is the REST policy (:data:`app.security.CSP`): no other site's
#: script, style, image or connection, no plugins, no framing.
VISER_CSP = ("default-src 'self'; "
             "script-src 'self' 'unsafe-inline' 'unsafe-eval' 'wasm-unsafe-eval'; "
             "style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
             "font-src 'self' data:; connect-src 'self' data:; worker-src 'self' blob:; "
             "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'none'")

_HEADERS = {
    "Content-Security-Policy": VISER_CSP,
    "X-Frame-Options": "DENY",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cross-Origin-Opener-Policy": "same-origin",
}
_INSTALL_LOCK = threading.Lock()
#: Largest websocket message a tab may send, bytes (an upload part is 512 KiB).
MAX_MESSAGE_BYTES = 2 * 1024 * 1024
#: Frames of one websocket that may wait unread.
MAX_QUEUED_FRAMES = 4
#: Uploads one tab may have in flight at once.
MAX_UPLOADS_PER_TAB = 2
#: Smallest upload part viser's client sends but for the last one, bytes (it sends 512 KiB).
MIN_PART_BYTES = 64 * 1024
#: Cookie of the viser page that names the browser (a random id, never a session code).
BROWSER_COOKIE = "hyst_viser"
#: How long a browser id is kept, s (a month: a course's sessions live about as long).
BROWSER_COOKIE_S = 30 * 24 * 3600
_BROWSER_ID = re.compile(r"^[A-Za-z0-9_-]{16,64}$")


def _cookie(headers: Any, name: str) -> str | None:
    """The value of cookie ``name`` in a request's ``Cookie`` headers (a valid browser id
    only), else None."""
    for value in headers.get_all("Cookie"):
        for part in str(value).split(";"):
            key, _, val = part.strip().partition("=")
            if key == name and _BROWSER_ID.match(val):
                return val
    return None


#: See :attr:`ViserGuard.upload_check`.
UploadCheck = Callable[[int, str, str, int, "bytes | None"], "str | None"]


class ViserGuardError(RuntimeError):
    """viser changed its internals: the guard cannot be installed (refuse to serve)."""


def check_viser(version: str) -> None:
    """Refuse a viser version whose internals were not checked.

    Raises
    ------
    ViserGuardError
        ``version`` is not one of :data:`SUPPORTED_VISER`; the message says what to do.
    """
    if not version.startswith(SUPPORTED_VISER):
        raise ViserGuardError(
            f"viser {version} is installed, but the explorer's viser guard (Host and Origin "
            f"checks, security headers) was checked only against viser "
            f"{', '.join(v + 'x' for v in SUPPORTED_VISER)}; install that version "
            "(pip install 'viser==1.1.1'), or run without the GUI (hyst serve --no-viser), "
            "or update app/gui/viser_guard.py after reading viser's infra/_infra.py")


class ViserGuard:
    """Wraps viser's ``process_request``; see the module docstring.

    Parameters
    ----------
    hosts : HostAllowList
        The names a request's ``Host`` may carry.
    trusted_proxies : tuple of str
        Proxies whose ``X-Forwarded-For`` names the client (``Settings.trusted_proxies``).
    max_tabs_per_client, max_tabs : int
        Open websockets one client address may hold, and the server in all
        (``Settings.max_tabs_per_client``, ``Settings.max_tabs``).
    max_upload_bytes : int
        Largest file a tab may upload (``Settings.max_upload_bytes``).
    """

    def __init__(self, hosts: HostAllowList, trusted_proxies: tuple[str, ...] = (), *,
                 max_tabs_per_client: int = 8, max_tabs: int = 300,
                 max_upload_bytes: int = 5_000_000) -> None:
        self.hosts = hosts
        self.trusted_proxies = trusted_proxies
        self.max_tabs_per_client = max_tabs_per_client
        self.max_tabs = max_tabs
        self.max_upload_bytes = max_upload_bytes
        self.installed = False
        #: The explorer's check of an upload: ``(client id, upload button's uuid, file name,
        #: declared size in bytes, first bytes or None)`` -> why it is refused (words), or
        #: None. Called on the start message (first bytes None) and on the first part.
        self.upload_check: UploadCheck | None = None
        self._addresses: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()
        self._browsers: weakref.WeakKeyDictionary[Any, str] = weakref.WeakKeyDictionary()
        self._server: Any = None

    def wrap(self, process_request: Callable[[Any, Any], Any] | None
             ) -> Callable[[Any, Any], Any]:
        """``process_request`` (viser's page server) behind this guard's checks."""

        def guarded(connection: Any, request: Any) -> Any:
            refused = self.refusal(connection, request)
            if refused is not None:
                return refused
            if _is_upgrade(request):
                address = client_address(_peer(connection),
                                         request.headers.get_all("X-Forwarded-For"),
                                         self.trusted_proxies)
                refused = self.tab_refusal(connection, address)
                if refused is not None:
                    return refused
                self._addresses[connection] = address
                browser = _cookie(request.headers, BROWSER_COOKIE)
                if browser is not None:
                    self._browsers[connection] = browser
                return None
            response = None if process_request is None else process_request(connection,
                                                                             request)
            if response is not None:
                _add_headers(response)
                if _cookie(request.headers, BROWSER_COOKIE) is None and \
                        "html" in str(response.headers.get("Content-Type", "")):
                    response.headers["Set-Cookie"] = (
                        f"{BROWSER_COOKIE}={secrets.token_urlsafe(18)}; Path=/; "
                        f"Max-Age={BROWSER_COOKIE_S}; HttpOnly; SameSite=Strict")
            return response

        self.installed = True
        return guarded

    def refusal(self, connection: Any, request: Any) -> Any:
        """The response refusing ``request`` (421 foreign Host, 403 foreign Origin), or
        ``None`` when it may go on."""
        headers = {k.lower(): v for k, v in request.headers.raw_items()}
        host = headers.get("host")
        local = getattr(connection, "local_address", None)
        if not self.hosts.allows(host, None if not local else str(local[0])):
            return _refuse(connection, http.HTTPStatus.MISDIRECTED_REQUEST,
                           f"this server does not answer to the name "
                           f"{host_name(host or '')[:100]!r} (the request's Host); open it "
                           "by its own address (as `hyst serve` printed it), or start it "
                           "with --allowed-host NAME to add that name")
        if not _is_upgrade(request):  # a link from another site is a cross-site navigation
            headers.pop("sec-fetch-site", None)
        why = foreign_origin(headers)
        if why is not None:
            return _refuse(connection, http.HTTPStatus.FORBIDDEN, why)
        return None

    def open_tabs(self) -> dict[str, int]:
        """Open (or opening) websockets per client address."""
        counts: dict[str, int] = {}
        for connection, address in list(self._addresses.items()):
            if _open(connection):
                counts[address] = counts.get(address, 0) + 1
        return counts

    def tab_refusal(self, connection: Any, address: str) -> Any:
        """The response refusing one more tab of ``address`` (429 beyond
        :attr:`max_tabs_per_client`, 503 beyond :attr:`max_tabs`), or ``None``. Runs on
        the websocket server's event loop, like every handshake, so counting and
        recording the new connection do not race."""
        counts = self.open_tabs()
        if counts.get(address, 0) >= self.max_tabs_per_client:
            response = _refuse(
                connection, http.HTTPStatus.TOO_MANY_REQUESTS,
                f"this computer already has {self.max_tabs_per_client} explorer tabs open, "
                "the most one computer may keep; close the tabs you do not use (to "
                "continue a session in another tab, type its code there), or ask the "
                "teacher to raise HYST_MAX_TABS_PER_CLIENT")
            response.headers["Retry-After"] = "5"
            return response
        if sum(counts.values()) >= self.max_tabs:
            response = _refuse(
                connection, http.HTTPStatus.SERVICE_UNAVAILABLE,
                f"the explorer already serves {self.max_tabs} open tabs, the most it may; "
                "try again in a minute, or ask the teacher to raise HYST_MAX_TABS")
            response.headers["Retry-After"] = "30"
            return response
        return None

    def _connection(self, client_id: int) -> Any:
        live = getattr(getattr(self._server, "_websock_server", None), "_live_connections", {})
        return live.get(client_id)

    def client_address(self, client_id: int) -> str:
        """The client address of the live websocket ``client_id`` (``"unknown"`` when gone)."""
        connection = self._connection(client_id)
        return "unknown" if connection is None else self._addresses.get(connection, "unknown")

    def browser_id(self, client_id: int) -> str | None:
        """The browser id (cookie :data:`BROWSER_COOKIE`) of the live websocket
        ``client_id``, or None (no cookie, or gone)."""
        connection = self._connection(client_id)
        return None if connection is None else self._browsers.get(connection)


def _is_upgrade(request: Any) -> bool:
    return str(request.headers.get("Upgrade", "")).lower() == "websocket"


def _open(connection: Any) -> bool:
    """Whether a websocket is connecting or open (not closing or closed)."""
    from websockets.protocol import State

    return getattr(connection, "state", State.CLOSED) in (State.CONNECTING, State.OPEN)


def _peer(connection: Any) -> str | None:
    remote = getattr(connection, "remote_address", None)
    return None if not remote else str(remote[0])


def _add_headers(response: Any) -> None:
    for name, value in _HEADERS.items():
        if name not in response.headers:
            response.headers[name] = value


def _refuse(connection: Any, status: http.HTTPStatus, text: str) -> Any:
    response = connection.respond(status, text + "\n")
    _add_headers(response)
    return response


def _upload_refusal(api: Any, client_id: int, message: Any, max_bytes: int) -> str | None:
    """Why the upload ``message`` (viser's ``FileTransferStartUpload``) is refused, or
    ``None``."""
    size, parts = int(message.size_bytes), int(message.part_count)
    if size > max_bytes:
        return (f"{str(message.filename)[:80]!r} has {size:,} bytes; files up to "
                f"{max_bytes:,} bytes are accepted")
    if size < 0 or not 0 <= parts <= size // MIN_PART_BYTES + 1:
        return "the upload was malformed; reload the page and try again"
    busy = sum(1 for st in api._current_file_upload_states.values()
               if st.get("client_id") == client_id)
    if busy >= MAX_UPLOADS_PER_TAB:
        return (f"this tab already uploads {busy} files; wait until they are done and "
                "try again")
    return None


def _end_refused(api: Any, component: str, transfer: str, size: int, why: str) -> None:
    """Tell a tab its upload ``transfer`` was refused: its client's upload state is ended
    (an acknowledgement of the whole size: viser's button is disabled until it sees one),
    its progress toast hidden and a red toast says ``why``."""
    from viser import _messages

    owner = getattr(api, "_owner", None)
    if not hasattr(owner, "add_notification"):  # not a tab's own GUI
        return
    api._websock_interface.queue_message(_messages.FileTransferPartAck(
        source_component_uuid=component, transfer_uuid=transfer,
        transferred_bytes=size, total_bytes=size))
    # the client's toast for this upload is named "upload-" + the transfer's uuid
    api._websock_interface.queue_message(
        _messages.RemoveNotificationMessage(uuid="upload-" + transfer))
    owner.add_notification("Not uploaded", why, auto_close_seconds=12.0, color="red")


def bound_uploads(guard: ViserGuard) -> None:
    """Bound what viser keeps of uploads (see the module docstring): wraps the two upload
    handlers of ``viser._gui_api.GuiApi`` (bound to each tab's GUI when it is made, so this
    runs before the server starts; idempotent, the newest guard's limit applies)."""
    from viser import _gui_api

    cls = _gui_api.GuiApi
    start = getattr(cls._handle_file_transfer_start, "__wrapped__",
                    cls._handle_file_transfer_start)
    part = getattr(cls._handle_file_transfer_part, "__wrapped__",
                   cls._handle_file_transfer_part)

    def check(self: Any, client_id: Any, uuid: str, name: str, size: int,
              head: bytes | None) -> str | None:
        if guard.upload_check is None:
            return None
        return guard.upload_check(client_id, str(uuid), str(name)[:200], size, head)

    @functools.wraps(start)
    def bounded_start(self: Any, client_id: Any, message: Any) -> Any:
        why = check(self, client_id, message.source_component_uuid, message.filename,
                    int(message.size_bytes), None)
        if why is None:
            why = _upload_refusal(self, client_id, message, guard.max_upload_bytes)
        if why is None:
            return start(self, client_id, message)
        _end_refused(self, message.source_component_uuid, message.transfer_uuid,
                     int(message.size_bytes), why)
        return None

    @functools.wraps(part)
    def bounded_part(self: Any, client_id: Any, message: Any) -> Any:
        st = self._current_file_upload_states.get(message.transfer_uuid)
        if st is not None and (st.get("client_id") != client_id or st["transferred_bytes"]
                               + len(message.content) > st["total_bytes"]):
            self._current_file_upload_states.pop(message.transfer_uuid, None)
            return None
        if st is not None and message.part_index == 0 and not st["parts"]:
            why = check(self, client_id, message.source_component_uuid, st["filename"],
                        int(st["total_bytes"]), bytes(message.content))
            if why is not None:
                self._current_file_upload_states.pop(message.transfer_uuid, None)
                _end_refused(self, message.source_component_uuid, message.transfer_uuid,
                             int(st["total_bytes"]), why)
                return None
        return part(self, client_id, message)

    cls._handle_file_transfer_start = bounded_start  # type: ignore[method-assign]
    cls._handle_file_transfer_part = bounded_part  # type: ignore[method-assign]


def start_viser(host: str, port: int, guard: ViserGuard) -> Any:
    """A started ``viser.ViserServer`` on ``host:port`` whose requests pass ``guard``.

    ``websockets.asyncio.server.serve`` is wrapped only while the server starts (viser's
    ``start`` returns once its ``serve`` is listening), under a lock, and only for viser's
    own call (its ``process_request`` is ``viser_http_server``).

    Raises
    ------
    ViserGuardError
        The viser version is not supported, or its start-up no longer goes through the
        wrapped call (its internals changed): the server is stopped, nothing is served.
    """
    import viser
    import websockets.asyncio.server as ws_server

    check_viser(viser.__version__)
    with _INSTALL_LOCK:
        bound_uploads(guard)
        original = ws_server.serve

        def serve(*args: Any, **kwargs: Any) -> Any:
            callback = kwargs.get("process_request")
            if getattr(callback, "__name__", "") == "viser_http_server":
                kwargs["process_request"] = guard.wrap(callback)
                kwargs["max_size"] = MAX_MESSAGE_BYTES
                kwargs["max_queue"] = MAX_QUEUED_FRAMES
            return original(*args, **kwargs)

        ws_server.serve = serve  # type: ignore[misc,assignment]
        try:
            server = viser.ViserServer(host=host, port=port, verbose=False)
        finally:
            ws_server.serve = original  # type: ignore[misc]
    if not guard.installed or not hasattr(getattr(server, "_websock_server", None),
                                          "_live_connections"):
        server.stop()
        raise ViserGuardError(
            f"viser {viser.__version__} no longer starts its websocket server the way the "
            "explorer's viser guard expects, so its Host and Origin checks are not in "
            "place and the GUI is not served; install viser 1.1.1, run without the GUI "
            "(hyst serve --no-viser), or update app/gui/viser_guard.py")
    guard._server = server
    return server
