"""Figures shared by the sessions that show the same config (issue 33: a class of thirty).

When the teacher moves the class to a lesson step, every student's session gets the step's
config, and every student's page (or viser tab) asks for the step's figures at once. They
are the same figures: :class:`SharedResults` computes them once per content key and hands
the same outcome to every session that asks for the same key; a student who moved (another
model, signal or view) has another key and gets their own. The key is the content's hash
(:func:`content_key`), so a new step, a push or a slider step simply makes a new key: nothing
is invalidated by hand, and the least recently used keys are dropped beyond
:data:`SHARED_MAX`.

Requests for a key that is being computed wait for that computation instead of starting their
own (the web page's requests run in worker threads, the viser tabs in their render threads).
What is shared is the outcome without its session's version; the caller puts its own
version in (:func:`with_version`). No web imports.
"""

from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from app.services.explore.config import Config
from app.services.explore.simulation import Result

__all__ = ["SHARED_MAX", "SharedResults", "STEP_RESULTS", "content_key", "with_version"]

#: How many configs' outcomes are kept (a class on one step, a few students elsewhere;
#: a payload of the default session's loop and time views is about 100 kB).
SHARED_MAX = 16


def content_key(kind: str, config: Config, views: tuple[str, ...], *extra: Any) -> str:
    """The hash of what determines an outcome: ``kind`` (what is computed: a figures body,
    a result), the config's content (model document, signal, mismatch, input source), the
    views in their order and ``extra`` (the limits, the highlighted state, ...), JSON with
    sorted keys, SHA-256."""
    doc = {"kind": kind, "config": config.to_dict(), "views": list(views), "extra": extra}
    text = json.dumps(doc, sort_keys=True, separators=(",", ":"), default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def with_version(out: Any, version: int) -> Any:
    """``out`` (a figures body or a :class:`Result`) as the session at ``version`` shows it:
    a copy with its ``version`` (the shared outcome itself is never changed)."""
    if isinstance(out, Result):
        return out if out.version == version else replace(out, version=version)
    if isinstance(out, dict) and "version" in out:
        return {**out, "version": version}
    return out


class SharedResults:
    """A small least-recently-used map of content key -> outcome, computed once per key.

    Parameters
    ----------
    max_items : int
        The most outcomes kept.
    """

    def __init__(self, max_items: int = SHARED_MAX) -> None:
        self.max_items = max_items
        self._items: OrderedDict[str, Any] = OrderedDict()
        self._lock = threading.Lock()
        self._computing: dict[str, threading.Lock] = {}
        #: Outcomes computed (misses), and asks answered from the map (hits).
        self.computed = 0
        self.hits = 0

    def get(self, key: str, compute: Callable[[], Any],
            keep: Callable[[Any], bool] = lambda out: True) -> Any:
        """The outcome of ``key``: kept, or ``compute()`` once while other askers of the same
        key wait for it; kept only when ``keep(outcome)`` (a refusal is not kept: it is
        computed again, as without this map)."""
        with self._lock:
            if key in self._items:
                self._items.move_to_end(key)
                self.hits += 1
                return self._items[key]
            busy = self._computing.setdefault(key, threading.Lock())
        with busy:  # one computation per key; the others wait here and then find it
            with self._lock:
                if key in self._items:
                    self._items.move_to_end(key)
                    self.hits += 1
                    return self._items[key]
                self.computed += 1
            try:
                out = compute()
            except BaseException:
                with self._lock:
                    self._computing.pop(key, None)
                raise
            with self._lock:
                if keep(out):
                    self._items[key] = out
                    self._items.move_to_end(key)
                    while len(self._items) > self.max_items:
                        self._items.popitem(last=False)
                self._computing.pop(key, None)
            return out

    def clear(self) -> None:
        """Forget every outcome (and the counts)."""
        with self._lock:
            self._items.clear()
            self.computed = self.hits = 0

    def __len__(self) -> int:
        return len(self._items)


#: The server's shared outcomes: figures bodies of the web page's requests and results of
#: the viser tabs' renders (:mod:`app.services.session.actions`).
STEP_RESULTS = SharedResults()
