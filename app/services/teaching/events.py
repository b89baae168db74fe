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
import time
from collections import deque
from dataclasses import dataclass, field
from typing import Any, TypedDict

from app.services.explore.config import SignalDoc

__all__ = ["HUB", "ClassStepDoc", "Event", "EventHub", "PushNote", "Roster",
           "StreamsPerClientError", "Subscription", "person_name"]

#: Events kept for one slow subscriber before the oldest are dropped.
QUEUE_SIZE = 64
#: Recent events kept for pages that reconnect.
REPLAY = 64
#: Longest name a student may give (characters).
NAME_MAX = 40
#: How long a page whose stream ended at its time limit still counts as open (s): it
#: reconnects within about half a second (``retry: 500``), so the teacher's counts do not
#: drop a page that is between two streams.
RETURN_S = 3.0


class ClassStepDoc(TypedDict):
    """The step the class is at, as a page shows it
    (:meth:`app.services.teaching.lessons.Position.to_dict`, ``GET /api/lesson``)."""

    running: bool
    title: str
    #: the shipped lesson's key, else None
    name: str | None
    #: 1-based step and number of steps
    step: int
    steps: int
    #: increases with every move of the class
    serial: int
    step_title: str
    prompt: str
    look_for: str
    view: str
    preset: str | None
    #: the step's model document
    model: dict[str, Any]
    input: SignalDoc
    mismatch: float


class PushNote(TypedDict, total=False):
    """What a teacher's push tells the pages and tabs beside ``kind`` (every key optional).

    ``preset`` the preset pushed (or None), ``title`` what was pushed in words, ``signal``
    / ``model`` whether an input / a model was pushed, ``lesson`` the class step it made or
    changed, ``edit`` the step was changed (not moved to), ``by`` the viser tab that pushed
    (it says "Pushed" itself)."""

    preset: str | None
    title: str | None
    signal: bool
    model: bool
    lesson: ClassStepDoc | None
    edit: bool
    by: int


class Event(PushNote, total=False):
    """A live event (server-sent ``event: kind``, ``data:`` this object as JSON): ``kind``
    ``"push"`` (a teacher's push, with its :class:`PushNote`) or ``"lesson"`` (the class's
    lesson ended: ``lesson`` None); ``id`` given by the hub, increasing."""

    kind: str
    id: int


def person_name(text: object) -> str:
    """A name a student typed, as the teacher's list shows it: control characters
    removed, spaces collapsed, at most :data:`NAME_MAX` characters (``""`` for none)."""
    cleaned = "".join(c if c.isprintable() else " " for c in str(text or ""))
    return " ".join(cleaned.split())[:NAME_MAX]


@dataclass(frozen=True)
class Roster:
    """Who is connected, without session codes (a projected teacher panel shows it).

    Attributes
    ----------
    web_pages : int
        Open web pages (live event streams).
    viser_tabs : int
        Open viser tabs.
    sessions_live : int
        Distinct sessions with an open page or tab.
    names : tuple of str
        The names students gave, sorted (each once).
    unnamed : int
        Pages and tabs without a name.
    """

    web_pages: int
    viser_tabs: int
    sessions_live: int
    names: tuple[str, ...]
    unnamed: int

    @property
    def text(self) -> str:
        """The roster in one sentence (counts and names, never codes)."""
        total = self.web_pages + self.viser_tabs
        if not total:
            return "Nobody is connected yet: students open the explorer's address."
        head = self.open_text
        who = ", ".join(self.names) if self.names else "nobody gave a name"
        if self.names and self.unnamed:
            who += f", and {self.unnamed} without a name"
        return f"{head}. Names: {who}."

    @property
    def open_text(self) -> str:
        """The counts alone: ``"2 web pages and 1 3D / GUI tab open, in 3 sessions"``."""
        s = lambda n, w: f"{n} {w}" + ("" if n == 1 else "s")  # noqa: E731
        return (f"{s(self.web_pages, 'web page')} and {s(self.viser_tabs, '3D / GUI tab')} "
                f"open, in {s(self.sessions_live, 'session')}")

    def sent_text(self, what: str) -> str:
        """What the teacher reads after a push or a lesson move (``what``: "Pushed a
        model", "Step 2 of 6 sent"): the class that is connected now (the counts of
        :attr:`text`, never the sessions of the last hour that no page shows)."""
        if not self.web_pages + self.viser_tabs:
            return f"{what}: stored, but no page or tab is open to show it."
        return f"{what} to the class: {self.open_text}."


class StreamsPerClientError(OverflowError):
    """One client already holds as many open streams as it may."""


@dataclass(eq=False)
class Subscription:
    """One listening page: its session code, loop, client and queue of event dicts."""

    code: str
    loop: asyncio.AbstractEventLoop
    client: str | None = None
    name: str = ""
    queue: asyncio.Queue[Event | None] = field(
        default_factory=lambda: asyncio.Queue(QUEUE_SIZE))

    def deliver(self, event: Event | None) -> None:
        """Put ``event`` on the queue (called in the loop's thread); drop the oldest if full."""
        if self.queue.full():
            try:
                self.queue.get_nowait()
            except asyncio.QueueEmpty:  # pragma: no cover - raced with the reader
                pass
        self.queue.put_nowait(event)

    async def get(self, timeout: float) -> Event | None:
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
        self._recent: deque[tuple[str | None, Event]] = deque(maxlen=REPLAY)
        # viser tabs: key -> (session code, name); they get events through listeners
        self._tabs: dict[object, tuple[str, str]] = {}
        self._listeners: list[Any] = []
        # pages between two streams: (client, code, name) -> when their streams ended
        self._returning: dict[tuple[str | None, str, str], list[float]] = {}

    def subscribe(self, code: str, last_id: int | None = None, *, client: str | None = None,
                  per_client: int | None = None, name: str = "") -> Subscription:
        """Listen to session ``code`` from the running asyncio loop.

        ``last_id`` (a reconnecting page's ``Last-Event-ID``) replays the kept events
        with a larger id that were meant for ``code``. With ``per_client``, ``client`` may
        hold at most that many streams at once (:class:`StreamsPerClientError` beyond,
        an ``OverflowError``); everyone together at most ``max_subscribers``.
        """
        sub = Subscription(code, asyncio.get_running_loop(), client, person_name(name))
        with self._lock:
            if per_client is not None and client is not None and \
                    self._per_client.get(client, 0) >= per_client:
                raise StreamsPerClientError(
                    f"{client} already holds {per_client} open event streams")
            if sum(map(len, self._subs.values())) >= self.max_subscribers:
                raise OverflowError(f"more than {self.max_subscribers} open event streams")
            self._subs.setdefault(code, []).append(sub)
            back = self._returning.get((client, code, sub.name))
            if back:  # a page back after its stream's time limit: counted once
                back.pop(0)
            if client is not None:
                self._per_client[client] = self._per_client.get(client, 0) + 1
            if last_id is not None:
                for target, ev in self._recent:
                    if ev["id"] > last_id and target in (None, code):
                        sub.deliver(ev)
        return sub

    def unsubscribe(self, sub: Subscription, *, returning: bool = False) -> None:
        """Stop delivering to ``sub`` (no error if it is gone already). ``returning``: the
        stream ended at its time limit and its page reconnects at once, so the roster keeps
        counting it for :data:`RETURN_S` seconds."""
        with self._lock:
            subs = self._subs.get(sub.code, [])
            if sub in subs:
                subs.remove(sub)
                if returning:
                    self._returning.setdefault((sub.client, sub.code, sub.name), []).append(
                        time.monotonic())
                if sub.client is not None:
                    left = self._per_client.pop(sub.client, 1) - 1
                    if left > 0:
                        self._per_client[sub.client] = left
            if not subs:
                self._subs.pop(sub.code, None)

    def _send(self, subs: list[Subscription], event: Event | None) -> int:
        sent = 0
        for sub in subs:
            try:
                sub.loop.call_soon_threadsafe(sub.deliver, event)
                sent += 1
            except RuntimeError:  # the loop is closed: the page is gone
                self.unsubscribe(sub)
        return sent

    def _stamp(self, target: str | None, event: Event) -> Event:
        ev: Event = {**event, "id": next(self._ids)}
        self._recent.append((target, ev))
        return ev

    def publish(self, code: str, event: Event) -> int:
        """Send ``event`` to every page of session ``code``; returns how many got it."""
        with self._lock:
            ev = self._stamp(code, event)
            subs = list(self._subs.get(code, ()))
        return self._send(subs, ev)

    def broadcast(self, event: Event) -> int:
        """Send ``event`` to every listening page of every session, and to the listeners
        (:meth:`add_listener`: the viser tabs); returns how many pages and tabs got it."""
        with self._lock:
            ev = self._stamp(None, event)
            subs = [s for group in self._subs.values() for s in group]
            listeners = list(self._listeners)
        told = sum(int(fn(ev) or 0) for fn in listeners)
        return self._send(subs, ev) + told

    def add_listener(self, fn: Any) -> None:
        """Call ``fn(event)`` on each broadcast (in the caller's thread); it returns how
        many tabs it told."""
        with self._lock:
            self._listeners.append(fn)

    def remove_listener(self, fn: Any) -> None:
        """Stop calling ``fn`` (no error if it is gone)."""
        with self._lock:
            if fn in self._listeners:
                self._listeners.remove(fn)

    def attend(self, key: object, code: str, name: str = "") -> None:
        """Count a viser tab ``key`` as connected to session ``code`` under ``name``."""
        with self._lock:
            self._tabs[key] = (code, person_name(name))

    def leave(self, key: object) -> None:
        """The viser tab ``key`` closed."""
        with self._lock:
            self._tabs.pop(key, None)

    def roster(self) -> Roster:
        """Who is connected: counts and names, no codes (see :class:`Roster`)."""
        with self._lock:
            pages = [(s.code, s.name) for group in self._subs.values() for s in group]
            tabs = list(self._tabs.values())
            old = time.monotonic() - RETURN_S
            for key, ends in list(self._returning.items()):
                ends[:] = [t for t in ends if t > old]
                if not ends:
                    del self._returning[key]
                pages += [(key[1], key[2])] * len(ends)
        names = [n for _, n in pages] + [n for _, n in tabs]
        codes = {c for c, _ in pages} | {c for c, _ in tabs}
        return Roster(len(pages), len(tabs), len(codes),
                      tuple(sorted({n for n in names if n}, key=str.casefold)),
                      sum(1 for n in names if not n))

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
