"""The viser side of ``hyst serve``: one private :class:`SessionView` per browser tab."""

from __future__ import annotations

import threading
from typing import Any

from ..services.sessions import SessionRegistry
from ..services.settings import Settings
from .controller import SessionView
from .layout import NARROW_PX

__all__ = ["ExplorerGui", "attach_gui"]


class ExplorerGui:
    """Binds a viser server to the session registry: one :class:`SessionView` per tab.

    Parameters
    ----------
    server : viser.ViserServer
    registry : SessionRegistry
    settings : Settings
    """

    def __init__(self, server: Any, registry: SessionRegistry, settings: Settings) -> None:
        self.server = server
        self.registry = registry
        self.settings = settings
        self.views: dict[int, SessionView] = {}
        self._lock = threading.Lock()
        server.gui.configure_theme(show_share_button=False, control_width="large",
                                   titlebar_content=None, show_logo=False)
        server.on_client_connect(self._connect)
        server.on_client_disconnect(self._disconnect)

    def _connect(self, client: Any) -> None:
        client.gui.configure_theme(show_share_button=False, control_width="large",
                                   show_logo=False)

        def notify(title: str, body: str, error: bool) -> None:
            client.add_notification(title, body, auto_close_seconds=6.0,
                                    color="red" if error else None)

        view = SessionView(client.gui, self.registry, self.registry.create(), self.settings,
                           notify=notify, scene=client.scene, camera=client.camera)

        def on_camera(camera: Any) -> None:
            width = getattr(camera, "image_width", 0) or 0
            if width:
                view.set_narrow(width < NARROW_PX)

        client.camera.on_update(on_camera)
        on_camera(client.camera)
        with self._lock:
            self.views[client.client_id] = view

    def _disconnect(self, client: Any) -> None:
        with self._lock:
            view = self.views.pop(client.client_id, None)
        if view is not None:
            view.close()

    def close(self) -> None:
        """Stop every view's worker."""
        with self._lock:
            views, self.views = list(self.views.values()), {}
        for v in views:
            v.close()


def attach_gui(server: Any, registry: SessionRegistry, settings: Settings) -> ExplorerGui:
    """Give every browser tab connecting to ``server`` its own explorer view."""
    return ExplorerGui(server, registry, settings)
