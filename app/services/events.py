"""In-process publish/subscribe of session events (teacher pushes) for live pages.

A :class:`EventHub` keeps, per session code, the queues of the pages that listen to it
(``GET /api/sessions/{code}/events``, server-sent events). :meth:`EventHub.publish` and
:meth:`EventHub.broadcast` may be called from any thread (a FastAPI worker thread, the
viser GUI's callbacks); each subscriber's queue belongs to an asyncio loop and is fed
with ``loop.call_soon_threadsafe``. Queues are bounded: a page that stops reading loses
its oldest events, never the server's memory. Every event gets an increasing ``id``;
the last :data:`REPLAY` events are kept so a page that reconnects (``Last-Event-ID``)
gets what it missed. No viser / fastapi imports.
"""

from __future__ import annotations

import asyncio
import itertools
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any

__all__ = ["HUB", "EventHub", "StreamsPerClientError", "Subscription"]

#: Events kept for one slow subscriber before the oldest are dropped.
QUEUE_SIZE = 64
#: Recent events kept for pages that reconnect.
REPLAY = 64


class StreamsPerClientError(OverflowError):
    """One client already holds as many open streams as it may."""


@dataclass(eq=False)
class Subscription:
    """One listening page: its session code, loop, client and queue of event dicts."""

    code: str
    loop: asyncio.AbstractEventLoop
    client: str | None = None
    queue: asyncio.Queue[dict[str, Any] | None] = field(
        default_factory=lambda: asyncio.Queue(QUEUE_SIZE))

    def deliver(self, event: dict[str, Any] | None) -> None:
        """Put ``event`` on the queue (called in the loop's thread); drop the oldest if full."""
        if self.queue.full():
            try:
                self.queue.get_nowait()
            except asyncio.QueueEmpty:  # pragma: no cover - raced with the reader
                pass
        self.queue.put_nowait(event)

    async def get(self, timeout: float) -> dict[str, Any] | None:
        """The next event; ``None`` when the hub closes; raises ``TimeoutError``."""
        return await asyncio.wait_for(self.queue.get(), timeout)


class EventHub:
    """Thread-safe registry of subscribers by session code.

    Parameters
    ----------
    max_subscribers : int
        Largest number of open streams; :meth:`subscribe` raises ``OverflowError`` beyond.
    """

    def __init__(self, max_subscribers: int = 2000) -> None:
        self.max_subscribers = max_subscribers
        self._lock = threading.Lock()
        self._subs: dict[str, list[Subscription]] = {}
        self._per_client: dict[str, int] = {}
        self._ids = itertools.count(1)
        self._recent: deque[tuple[str | None, dict[str, Any]]] = deque(maxlen=REPLAY)

    def subscribe(self, code: str, last_id: int | None = None, *, client: str | None = None,
                  per_client: int | None = None) -> Subscription:
        """Listen to session ``code`` from the running asyncio loop.

        ``last_id`` (a reconnecting page's ``Last-Event-ID``) replays the kept events
        with a larger id that were meant for ``code``. With ``per_client``, ``client`` may
        hold at most that many streams at once (:class:`StreamsPerClientError` beyond,
        an ``OverflowError``); everyone together at most ``max_subscribers``.
        """
        sub = Subscription(code, asyncio.get_running_loop(), client)
        with self._lock:
            if per_client is not None and client is not None and \
                    self._per_client.get(client, 0) >= per_client:
                raise StreamsPerClientError(
                    f"{client} already holds {per_client} open event streams")
            if sum(map(len, self._subs.values())) >= self.max_subscribers:
                raise OverflowError(f"more than {self.max_subscribers} open event streams")
            self._subs.setdefault(code, []).append(sub)
            if client is not None:
                self._per_client[client] = self._per_client.get(client, 0) + 1
            if last_id is not None:
                for target, ev in self._recent:
                    if ev["id"] > last_id and target in (None, code):
                        sub.deliver(ev)
        return sub

    def unsubscribe(self, sub: Subscription) -> None:
        """Stop delivering to ``sub`` (no error if it is gone already)."""
        with self._lock:
            subs = self._subs.get(sub.code, [])
            if sub in subs:
                subs.remove(sub)
                if sub.client is not None:
                    left = self._per_client.pop(sub.client, 1) - 1
                    if left > 0:
                        self._per_client[sub.client] = left
            if not subs:
                self._subs.pop(sub.code, None)

    def _send(self, subs: list[Subscription], event: dict[str, Any] | None) -> int:
        sent = 0
        for sub in subs:
            try:
                sub.loop.call_soon_threadsafe(sub.deliver, event)
                sent += 1
            except RuntimeError:  # the loop is closed: the page is gone
                self.unsubscribe(sub)
        return sent

    def _stamp(self, target: str | None, event: dict[str, Any]) -> dict[str, Any]:
        ev = {**event, "id": next(self._ids)}
        self._recent.append((target, ev))
        return ev

    def publish(self, code: str, event: dict[str, Any]) -> int:
        """Send ``event`` to every page of session ``code``; returns how many got it."""
        with self._lock:
            ev = self._stamp(code, event)
            subs = list(self._subs.get(code, ()))
        return self._send(subs, ev)

    def broadcast(self, event: dict[str, Any]) -> int:
        """Send ``event`` to every listening page of every session."""
        with self._lock:
            ev = self._stamp(None, event)
            subs = [s for group in self._subs.values() for s in group]
        return self._send(subs, ev)

    def newest_id(self) -> int:
        """The id of the newest event so far (0 before the first)."""
        with self._lock:
            return self._recent[-1][1]["id"] if self._recent else 0

    def connected(self) -> dict[str, int]:
        """Open streams per session code."""
        with self._lock:
            return {code: len(subs) for code, subs in self._subs.items() if subs}

    def close(self) -> None:
        """End every open stream (server shutdown); new streams may open afterwards."""
        with self._lock:
            subs = [s for group in self._subs.values() for s in group]
        self._send(subs, None)


#: The process-wide hub (one explorer per process).
HUB = EventHub()
