"""How much of the session store one client and one session may hold (no web imports).

The store's budget (``--max-store-mb``) is shared by a class; without a share per client one
computer could fill it and lock everyone out (issue 35: 169 sessions of 4.9 MB from one
address in 36 s). :class:`Quotas` bounds, per client address (the creator of a session,
:func:`app.services.guard.clients.client_address`), the stored bytes and the number of stored
sessions, and per session its stored bytes. A teacher's sessions are exempt from the
per-client limits. :class:`QuotaError` says which limit was reached and what to do.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["QuotaError", "Quotas"]

_MB = 1_000_000


def _mb(n: int) -> str:
    """``n`` bytes in MB as a person reads it (``1.5 MB``, ``100 MB``)."""
    return f"{n / _MB:.1f}".removesuffix(".0") + " MB"


@dataclass(frozen=True)
class Quotas:
    """Shares of the session store.

    Parameters
    ----------
    client_bytes : int
        Bytes the stored sessions created from one client address may hold together.
    client_sessions : int
        Stored sessions one client address may have created (and still be kept).
    session_bytes : int
        Bytes one session may hold (its recording, fit and diagnosis), stored.
    """

    client_bytes: int = 100 * _MB
    client_sessions: int = 500
    session_bytes: int = 20 * _MB

    def __post_init__(self) -> None:
        for name in ("client_bytes", "client_sessions", "session_bytes"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"the {name.replace('_', ' ')} quota must be at least 1, "
                                 f"got {getattr(self, name)}")


class QuotaError(RuntimeError):
    """A per-client or per-session share of the store was reached; the message is for the
    user (which limit, how much is held, what to do).

    Attributes
    ----------
    limit : str
        ``"client_bytes"``, ``"client_sessions"`` or ``"session_bytes"``.
    """

    def __init__(self, limit: str, message: str) -> None:
        super().__init__(message)
        self.limit = limit

    @classmethod
    def client_bytes(cls, held: int, adding: int, quota: int) -> QuotaError:
        """This client's sessions hold ``held`` bytes and ``adding`` more would pass
        ``quota``."""
        return cls("client_bytes", (
            f"the sessions opened from this computer already hold {_mb(held)} of "
            f"recordings and results, and this would add {_mb(adding)}: the limit "
            f"per computer is {_mb(quota)}. Keep working in a session you have "
            "(rejoin it with its code) instead of opening new ones; sessions of this "
            "computer unused for an hour make room. The teacher can raise the limit "
            "(hyst serve --max-client-store-mb)."))

    @classmethod
    def client_sessions(cls, held: int, quota: int) -> QuotaError:
        """This client created ``held`` stored sessions, the ``quota``."""
        return cls("client_sessions", (
            f"this computer has opened {held} sessions that are still kept, the limit per "
            f"computer ({quota}): rejoin one of them with its code instead of opening a new "
            "one; sessions unused for an hour make room. The teacher can raise the limit "
            "(hyst serve --max-sessions-per-client)."))

    @classmethod
    def session_bytes(cls, size: int, quota: int) -> QuotaError:
        """One session would hold ``size`` bytes, more than ``quota``."""
        return cls("session_bytes", (
            f"this session would hold {_mb(size)} of recordings and results; the "
            f"limit per session is {_mb(quota)}. Upload a shorter recording (fewer "
            "samples or columns). The teacher can raise the limit "
            "(hyst serve --max-session-mb)."))
