"""The viser side of ``hyst serve``: one private :class:`SessionView` per browser tab.

Each tab's new session counts against the per-client limiter of ``POST /api/sessions``
(keyed by the websocket's client address, :meth:`app.gui.viser_guard.ViserGuard.
client_address`): a client beyond it gets a message in the tab, not a session. How many
tabs a client may hold open is bounded before the websocket is accepted
(:mod:`app.gui.viser_guard`).

A closed tab's view is closed and forgotten, also when the tab closed while its view was
still being built (viser runs connect and disconnect callbacks concurrently on its thread
pool), and its memory is given back to the system (:mod:`app.gui.reclaim`).

A reloaded tab keeps its session: the browser's id (a cookie the guard sets,
:meth:`~app.gui.viser_guard.ViserGuard.browser_id`) maps to the session its last tab
showed. A teacher's push (:meth:`~app.services.teaching.events.EventHub.broadcast`) reaches every
tab as a notice.
"""

from __future__ import annotations

import threading
import warnings
from collections import OrderedDict
from typing import Any

from app.services.errors import QuotaError, StoreFullError
from app.services.guard.ratelimit import RateLimiter
from app.services.jobs.manager import JobManager
from app.services.session.sessions import SessionRegistry
from app.services.settings import Settings
from app.services.teaching.events import HUB

from .controller import SessionView
from .layout import is_narrow
from .reclaim import Reclaimer
from .toasts import Toasts
from .viser_guard import ViserGuard

__all__ = ["ExplorerGui", "attach_gui"]

#: Browsers whose last session is remembered (the oldest are forgotten beyond).
MAX_BROWSERS = 10_000

# a tab closed while its view is built makes viser warn once per tab that the rest of the
# build goes nowhere; expected here (the view is closed at the end of its build)
warnings.filterwarnings("ignore", message=r"Queued a \w+ on a closed connection",
                        category=UserWarning)


class ExplorerGui:
    """Binds a viser server to the session registry: one :class:`SessionView` per tab.

    Parameters
    ----------
    server : viser.ViserServer
    registry : SessionRegistry
    settings : Settings
    guard : ViserGuard, optional
        Knows each websocket's client address (:mod:`app.gui.viser_guard`).
    limiter : RateLimiter, optional
        New sessions per client address; no limit without one.
    jobs : JobManager, optional
        Runs the tabs' fits in killable worker processes (the REST API's manager, so a
        session has one job at a time whichever side started it); a shared one without.
    """

    def __init__(self, server: Any, registry: SessionRegistry, settings: Settings, *,
                 guard: ViserGuard | None = None, limiter: RateLimiter | None = None,
                 jobs: JobManager | None = None) -> None:
        self.server = server
        self.jobs = jobs
        self.registry = registry
        self.settings = settings
        self.guard = guard
        self.limiter = limiter
        self.refused: set[int] = set()
        #: Tabs whose connect was handled (a view made, refused, or closed meanwhile).
        self.answered = 0
        self.views: dict[int, SessionView] = {}
        self._lock = threading.Lock()
        self.reclaimer = Reclaimer()
        #: browser id -> the code of the session its last tab showed
        self._sessions: OrderedDict[str, str] = OrderedDict()
        HUB.add_listener(self._on_event)
        if guard is not None:
            guard.upload_check = self._upload_check
        server.gui.configure_theme(show_share_button=False, control_width="large",
                                   titlebar_content=None, show_logo=False)
        server.on_client_connect(self._connect)
        server.on_client_disconnect(self._disconnect)

    def _connect(self, client: Any) -> None:
        try:
            self._open_view(client)
        finally:
            with self._lock:
                self.answered += 1

    def _open_view(self, client: Any) -> None:
        client.gui.configure_theme(show_share_button=False, control_width="large",
                                   show_logo=False)

        # one toast per title: a newer one changes it in place (a lesson's quick moves
        # piled up "Lesson" toasts that climbed over the plot panel; removed and shown
        # again, each cost the tab two transitions, issue 33)
        notify = Toasts(client.add_notification)

        if not self._live(client):
            return
        browser = None if self.guard is None else self.guard.browser_id(client.client_id)
        session = self._known_session(browser)
        if session is None:
            if not self._may_create(client):
                return
            try:
                session = self.registry.create(owner=self._address(client))
            except (QuotaError, StoreFullError) as exc:
                self._refuse(client, f"**No new session.** {exc}")
                return

        def remember(code: str) -> None:
            if browser is not None:
                with self._lock:
                    self._sessions[browser] = code
                    self._sessions.move_to_end(browser)
                    while len(self._sessions) > MAX_BROWSERS:
                        self._sessions.popitem(last=False)

        view = SessionView(client.gui, self.registry, session, self.settings,
                           notify=notify, scene=client.scene, camera=client.camera,
                           on_session=remember, jobs=self.jobs, flush=client.flush,
                           atomic=client.atomic)

        def on_camera(camera: Any) -> None:
            width = getattr(camera, "image_width", 0) or 0
            if width:
                view.set_narrow(is_narrow(width, getattr(camera, "image_height", 0) or 0))

        client.camera.on_update(on_camera)
        on_camera(client.camera)
        with self._lock:
            live = self._live(client)
            if live:
                self.views[client.client_id] = view
        if not live:  # closed while its view was built: its disconnect found no view
            view.close()
        self.reclaimer.request()  # building a view leaves garbage too

    def _upload_check(self, client_id: int, uuid: str, name: str, size: int,
                      head: bytes | None) -> str | None:
        """Why the tab ``client_id``'s upload is refused before it is kept (its view's
        :meth:`~app.gui.controller.SessionView.upload_refusal`), or None."""
        with self._lock:
            view = self.views.get(client_id)
        return None if view is None else view.upload_refusal(uuid, name, size, head)

    def _live(self, client: Any) -> bool:
        """Whether ``client``'s tab is still open. viser drops a client from its list
        before it runs the disconnect callbacks, so a view stored under :attr:`_lock`
        while its client is listed is found by :meth:`_disconnect`."""
        return client.client_id in self.server.get_clients()

    def _known_session(self, browser: str | None) -> Any:
        """The session this browser's last tab showed (a reload keeps it), or None."""
        if browser is None:
            return None
        with self._lock:
            code = self._sessions.get(browser)
        if code is None:
            return None
        try:
            return self.registry.get(code)
        except Exception:  # noqa: BLE001 - expired or reset: a new session instead
            return None

    def _on_event(self, event: dict[str, Any]) -> int:
        """A broadcast (the teacher's push): a notice in every tab; returns how many."""
        if event.get("kind") != "push":
            return 0
        with self._lock:
            views = list(self.views.values())
        for v in views:
            v.pushed(event)
        return len(views)

    def _address(self, client: Any) -> str:
        """The client address of ``client``'s tab (per-client limits and shares)."""
        return "unknown" if self.guard is None else self.guard.client_address(client.client_id)

    def _may_create(self, client: Any) -> bool:
        """Whether this tab's client may have a new session; else say so in the tab."""
        if self.limiter is None:
            return True
        key = self._address(client)
        if self.limiter.take(key):
            return True
        wait = self.limiter.retry_after(key)
        self._refuse(client, f"**Too many new sessions from this computer.** Each open or "
                             f"reloaded tab starts one; close tabs you do not use and reload "
                             f"this page in {wait} s (to continue a session, use its code "
                             "after the reload).")
        return False

    def _refuse(self, client: Any, text: str) -> None:
        """Say in ``client``'s tab why it has no session (markdown ``text``)."""
        client.gui.add_markdown(text)
        client.add_notification("No session", text.replace("**", ""),
                                auto_close_seconds=None, color="red")
        with self._lock:
            if self._live(client):  # else its disconnect has passed already
                self.refused.add(client.client_id)

    def _disconnect(self, client: Any) -> None:
        with self._lock:
            self.refused.discard(client.client_id)
            view = self.views.pop(client.client_id, None)
        if view is not None:
            view.close()
        self.reclaimer.request()

    def close(self) -> None:
        """Stop every view's worker."""
        HUB.remove_listener(self._on_event)
        with self._lock:
            views, self.views = list(self.views.values()), {}
        for v in views:
            v.close()
        self.reclaimer.stop()


def attach_gui(server: Any, registry: SessionRegistry, settings: Settings, *,
               guard: ViserGuard | None = None,
               limiter: RateLimiter | None = None,
               jobs: JobManager | None = None) -> ExplorerGui:
    """Give every browser tab connecting to ``server`` its own explorer view (see
    :class:`ExplorerGui` for ``guard`` and ``limiter``)."""
    return ExplorerGui(server, registry, settings, guard=guard, limiter=limiter, jobs=jobs)
