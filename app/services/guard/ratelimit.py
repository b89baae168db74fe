"""Per-client token buckets (session creation, failed code look-ups); no web imports."""

from __future__ import annotations

import threading
import time
from collections import OrderedDict

__all__ = ["RateLimiter"]


class RateLimiter:
    """A token bucket per client key: ``burst`` tokens, refilled at ``per_minute``.

    Parameters
    ----------
    burst : int
        Tokens a new client starts with (the largest burst it may send).
    per_minute : float
        Refill rate, tokens per minute.
    max_clients : int
        Buckets kept (least recently seen clients are forgotten beyond it, so the table
        itself is bounded).
    """

    def __init__(self, burst: int, per_minute: float, max_clients: int = 10_000) -> None:
        self.burst = float(burst)
        self.rate = float(per_minute) / 60.0
        self.max_clients = max_clients
        self._lock = threading.Lock()
        self._buckets: OrderedDict[str, tuple[float, float]] = OrderedDict()

    def _level(self, key: str, now: float) -> float:
        tokens, last = self._buckets.get(key, (self.burst, now))
        return min(self.burst, tokens + (now - last) * self.rate)

    def allowed(self, key: str) -> bool:
        """Whether ``key`` has a token left (does not take one)."""
        with self._lock:
            return self._level(key, time.monotonic()) >= 1.0

    def take(self, key: str) -> bool:
        """Take a token from ``key``'s bucket; ``False`` (nothing taken) when it is empty."""
        now = time.monotonic()
        with self._lock:
            level = self._level(key, now)
            ok = level >= 1.0
            self._buckets[key] = (level - 1.0 if ok else level, now)
            self._buckets.move_to_end(key)
            while len(self._buckets) > self.max_clients:
                self._buckets.popitem(last=False)
            return ok

    def retry_after(self, key: str) -> int:
        """Seconds until ``key`` has a token again (at least 1)."""
        with self._lock:
            missing = 1.0 - self._level(key, time.monotonic())
        return max(1, int(missing / self.rate + 0.999)) if self.rate > 0 else 3600
