"""A viser tab's toasts: one per title, a newer one changing the one on show in place.

A lesson's every move toasts "Lesson" in every student's tab. Removed and shown again, the
toast cost each tab an exit and an enter transition per move (about 50 ms of the tab's main
thread per move, issue 33: a class of thirty on 2 cores); the toast on show now takes the
new text and its time again, and only a toast that has closed (or is about to) is shown anew.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import Any

__all__ = ["AUTO_CLOSE_S", "Toasts"]

#: Seconds a toast stays on show after it was shown or last changed.
AUTO_CLOSE_S = 6.0
#: A toast changed later than this after it was last shown or changed may have closed in
#: the browser meanwhile (a busy tab, a clock apart): it is shown anew instead, s.
CHANGE_WITHIN_S = AUTO_CLOSE_S - 1.5
#: The browser (Mantine) starts a toast's close timer again only when its duration changes:
#: each change alternates between the two durations, a millisecond apart.
_DURATIONS = (AUTO_CLOSE_S, AUTO_CLOSE_S + 0.001)


class Toasts:
    """``toasts(title, body, error)`` shows a toast in one tab (``add``: the tab's
    ``client.add_notification``); a toast of the same title and kind on show is changed in
    place (its body, its time again), else the old one is removed and a new one shown.

    Parameters
    ----------
    add : callable
        ``add(title, body, auto_close_seconds=..., color=...)`` returns a viser
        ``NotificationHandle``.
    clock : callable
        Seconds (``time.monotonic``).
    """

    def __init__(self, add: Callable[..., Any], clock: Callable[[], float] = time.monotonic
                 ) -> None:
        self._add = add
        self._clock = clock
        self._lock = threading.Lock()
        # title -> (handle, error, when shown or last changed, which duration it has)
        self._shown: dict[str, tuple[Any, bool, float, int]] = {}

    def __call__(self, title: str, body: str, error: bool) -> None:
        now = self._clock()
        with self._lock:
            old = self._shown.pop(title, None)
            if old is not None:
                handle, was_error, when, k = old
                if was_error == error and now - when < CHANGE_WITHIN_S:
                    try:
                        k = 1 - k
                        handle.body = body
                        handle.auto_close_seconds = _DURATIONS[k]
                        self._shown[title] = (handle, error, now, k)
                        return
                    except Exception:  # noqa: BLE001 - a closed tab: shown anew below
                        pass
                try:
                    handle.remove()
                except Exception:  # noqa: BLE001 - closed already (its 6 s are over)
                    pass
            handle = self._add(title, body, auto_close_seconds=_DURATIONS[0],
                               color="red" if error else None)
            self._shown[title] = (handle, error, now, 0)
