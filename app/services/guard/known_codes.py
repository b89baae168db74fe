"""The session codes each client has shown it knows; no web imports.

Unknown codes are rate-limited per client (a guessing attack tries many codes). A client
that is paused for guessing must still reach the sessions it created or opened before the
pause: the lock-out is of the pair (client, code), not of the client. A code is remembered
only after the server made it for that client or the client opened it while not paused,
so the answer to a paused client never tells whether a new guess exists.
"""

from __future__ import annotations

import threading
from collections import OrderedDict

__all__ = ["KnownCodes"]


class KnownCodes:
    """Per client, the most recent codes it created or opened (bounded in both directions).

    Parameters
    ----------
    per_client : int
        Codes kept per client (the oldest is forgotten beyond it).
    max_clients : int
        Clients kept (the least recently seen is forgotten beyond it).
    """

    def __init__(self, per_client: int = 32, max_clients: int = 10_000) -> None:
        self.per_client = per_client
        self.max_clients = max_clients
        self._lock = threading.Lock()
        self._codes: OrderedDict[str, OrderedDict[str, None]] = OrderedDict()

    def add(self, client: str, code: str) -> None:
        """Remember that ``client`` knows ``code`` (a canonical code)."""
        with self._lock:
            codes = self._codes.setdefault(client, OrderedDict())
            codes[code] = None
            codes.move_to_end(code)
            while len(codes) > self.per_client:
                codes.popitem(last=False)
            self._codes.move_to_end(client)
            while len(self._codes) > self.max_clients:
                self._codes.popitem(last=False)

    def knows(self, client: str, code: str) -> bool:
        """Whether ``client`` created or opened ``code`` before."""
        with self._lock:
            return code in self._codes.get(client, ())

    def forget(self, client: str, code: str) -> None:
        """Drop ``code`` from ``client``'s codes (the session is gone)."""
        with self._lock:
            self._codes.get(client, OrderedDict()).pop(code, None)
