"""Latest-wins rendering: one worker thread per view, stale versions are skipped."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable

__all__ = ["LatestWinsWorker"]


class LatestWinsWorker:
    """Run ``render()`` in a daemon thread whenever :meth:`request` is called.

    Requests that arrive while a render is running collapse into one follow-up render
    of the newest state, so a dragged slider (about 20 updates/s) never builds a backlog:
    the latest value wins and intermediate versions are skipped.

    Parameters
    ----------
    render : callable
        Draws the current state; exceptions are passed to ``on_error``.
    on_error : callable, optional
        Called with the exception a render raised.
    name : str
        Thread name.
    """

    def __init__(
        self,
        render: Callable[[], None],
        on_error: Callable[[BaseException], None] | None = None,
        name: str = "render",
    ) -> None:
        self._render = render
        self._on_error = on_error
        self._event = threading.Event()
        self._stop = False
        self._idle = threading.Event()
        self._idle.set()
        self.requests = 0
        self.renders = 0
        self.last_ms = 0.0
        self._thread = threading.Thread(target=self._loop, name=name, daemon=True)
        self._thread.start()

    def request(self) -> None:
        """Ask for a render of the newest state (cheap; never blocks)."""
        self.requests += 1
        self._idle.clear()
        self._event.set()

    def _loop(self) -> None:
        while True:
            self._event.wait()
            if self._stop:
                return
            self._event.clear()
            t0 = time.perf_counter()
            try:
                self._render()
            except BaseException as exc:  # noqa: BLE001 - reported, worker keeps running
                if self._on_error is not None:
                    self._on_error(exc)
            self.renders += 1
            self.last_ms = 1e3 * (time.perf_counter() - t0)
            if not self._event.is_set():
                self._idle.set()

    def wait_idle(self, timeout: float = 10.0) -> bool:
        """Block until no render is pending (tests and benchmarks)."""
        return self._idle.wait(timeout)

    def stop(self) -> None:
        """Stop the thread after the current render."""
        self._stop = True
        self._event.set()
        self._thread.join(timeout=5)
