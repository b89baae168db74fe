"""The names this server answers to (the ``Host`` allow-list against DNS rebinding).

A page of another site can point its own name at 127.0.0.1 (DNS rebinding): the browser
then sends that page's requests here, with ``Host`` and ``Origin`` both naming the other
site, so the origin check alone lets them through. Refusing every ``Host`` that is not a
name of this server closes that: :class:`HostAllowList` holds those names.
:func:`foreign_origin` is the other half, the Origin rule: a browser request that another
site's page sent. The REST guard (:mod:`app.security`) and the viser port's guard
(:mod:`app.gui.viser_guard`) both apply these two rules.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from urllib.parse import urlsplit

__all__ = ["LOOPBACK_NAMES", "WILDCARDS", "HostAllowList", "foreign_origin", "host_name"]

#: Names of this machine that every server answers to.
LOOPBACK_NAMES = ("localhost", "127.0.0.1", "::1")
#: Bind addresses meaning "every interface" (no name of their own).
WILDCARDS = frozenset({"", "0.0.0.0", "::", "[::]"})


def host_name(value: str) -> str:
    """The name of a ``Host`` header or a configured host: no port, no IPv6 brackets, no
    trailing dot, lower case (``[::1]:8000`` -> ``::1``, ``Example.ORG.:80`` -> ``example.org``).
    """
    v = value.strip().lower()
    if v.startswith("["):
        end = v.find("]")
        v = v[1:end] if end > 0 else v[1:]
    elif v.count(":") == 1:
        v = v.split(":", 1)[0]
    return v.rstrip(".")


@dataclass(frozen=True)
class HostAllowList:
    """The names a request's ``Host`` may carry.

    Parameters
    ----------
    names : frozenset of str
        Allowed names, normalised by :func:`host_name`.
    """

    names: frozenset[str]

    @classmethod
    def for_server(cls, bound: str, extra: tuple[str, ...] = ()) -> HostAllowList:
        """The loopback names, ``bound`` when it is not a wildcard, and ``extra``."""
        names = {host_name(n) for n in (*LOOPBACK_NAMES, *extra) if host_name(n)}
        if host_name(bound) not in {host_name(w) for w in WILDCARDS}:
            names.add(host_name(bound))
        return cls(frozenset(names))

    def allows(self, host: str | None, local_address: str | None = None) -> bool:
        """Whether a request with this ``Host`` header may be served.

        Parameters
        ----------
        host : str or None
            The ``Host`` header; a request without one (not a browser's) is allowed.
        local_address : str, optional
            The address the connection arrived at (the ASGI scope's ``server``): a
            student who typed the server's own address (``--host 0.0.0.0``) names it,
            which no other site can rebind.
        """
        if not host:
            return True
        name = host_name(host)
        if name in self.names:
            return True
        return local_address is not None and name == host_name(local_address)


def foreign_origin(headers: Mapping[str, str]) -> str | None:
    """Why a browser request comes from another site's page, or ``None`` when it does not.

    Parameters
    ----------
    headers : mapping of str to str
        The request's headers, names in lower case.

    Returns
    -------
    str or None
        A sentence for the user when ``Sec-Fetch-Site`` says ``cross-site`` or ``Origin``
        is not this server (``null``, malformed, or another host and port than ``Host``);
        ``None`` otherwise, also without an ``Origin`` (not a browser's cross-origin
        request: curl, scripts, same-origin GET).
    """
    if headers.get("sec-fetch-site") == "cross-site":
        return "requests from another web site may not change sessions"
    origin = headers.get("origin")
    if origin is None:
        return None
    host = headers.get("host", "")
    try:
        parts = urlsplit(origin)
    except ValueError:
        return "the request's Origin header is malformed"
    if origin == "null" or parts.netloc.lower() != host.lower():
        return (f"requests from another web site ({origin[:100]}) may not change "
                "sessions; open the explorer's own page")
    return None
