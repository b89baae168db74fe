"""Which client a request comes from: the socket's peer, or what a trusted proxy forwards.

The per-client limits (new sessions, unknown codes, live pages) are keyed by this address.
``X-Forwarded-For`` is written by whoever sends the request, so it is read only when the
request arrives from a proxy the server was told to trust (``hyst serve --trusted-proxy``);
then the right-most entry that is not itself a trusted proxy is the client (each proxy
appends the address it saw, so only entries to the right of the first untrusted one are
trustworthy). No web imports.
"""

from __future__ import annotations

import ipaddress
from collections.abc import Iterable

__all__ = ["client_address", "proxy_networks"]

Network = ipaddress.IPv4Network | ipaddress.IPv6Network


def proxy_networks(addresses: Iterable[str]) -> tuple[str, ...]:
    """The trusted proxies as network strings (``127.0.0.1`` -> ``127.0.0.1/32``).

    Parameters
    ----------
    addresses : iterable of str
        IP addresses or networks (``10.0.0.0/8``).

    Returns
    -------
    tuple of str
        Each in its canonical form.

    Raises
    ------
    ValueError
        An entry is not an IP address or network; the message names it and shows the form.
    """
    out: list[str] = []
    for raw in addresses:
        try:
            out.append(str(ipaddress.ip_network(str(raw).strip(), strict=False)))
        except ValueError:
            raise ValueError(
                f"trusted proxy {str(raw)[:60]!r} is not an IP address or network; give the "
                "address the proxy connects from, such as 127.0.0.1 or 10.0.0.0/8 "
                "(--trusted-proxy or HYST_TRUSTED_PROXIES)") from None
    return tuple(dict.fromkeys(out))


def _address(text: str) -> ipaddress.IPv4Address | ipaddress.IPv6Address | None:
    text = text.strip()
    if text.startswith("[") and "]" in text:  # [v6]:port
        text = text[1:text.index("]")]
    elif text.count(":") == 1:  # v4:port
        text = text.split(":")[0]
    try:
        return ipaddress.ip_address(text)
    except ValueError:
        return None


def _trusted(address: str, networks: tuple[Network, ...]) -> bool:
    ip = _address(address)
    return ip is not None and any(ip.version == n.version and ip in n for n in networks)


def client_address(peer: str | None, forwarded_for: Iterable[str],
                   trusted: Iterable[str]) -> str:
    """The address the per-client limits count a request against.

    Parameters
    ----------
    peer : str or None
        The socket's peer address (``None`` when unknown).
    forwarded_for : iterable of str
        The request's ``X-Forwarded-For`` header values, in order (each may list several
        comma-separated addresses).
    trusted : iterable of str
        Trusted proxy addresses or networks (:func:`proxy_networks`).

    Returns
    -------
    str
        ``peer`` unless it is a trusted proxy; then the right-most forwarded address that
        is not a trusted proxy (the left-most one when all are; ``peer`` when the header is
        missing or its entry is not an address).
    """
    peer = peer or "unknown"
    networks = tuple(ipaddress.ip_network(n, strict=False) for n in trusted)
    if not networks or not _trusted(peer, networks):
        return peer
    hops = [h.strip() for value in forwarded_for for h in value.split(",") if h.strip()]
    for hop in reversed(hops):
        if not _trusted(hop, networks):
            ip = _address(hop)
            return str(ip) if ip is not None else peer
    return str(_address(hops[0])) if hops else peer
