"""Run-time settings of the explorer (``hyst serve``): addresses, ports and limits."""

from __future__ import annotations

import hmac
import ipaddress
import os
import secrets
from dataclasses import dataclass, fields, replace

from app.services.explore.cost import Limits
from app.services.guard.clients import proxy_networks
from app.services.guard.hosts import HostAllowList
from app.services.jobs.worker import default_memory_limit
from app.services.runs.cost import DIAGNOSE, WORKER_START_BYTES
from app.services.storage.quotas import Quotas

__all__ = ["Settings", "is_loopback"]


@dataclass(frozen=True)
class Settings:
    """Addresses, ports and resource limits of one explorer process.

    Parameters
    ----------
    host : str
        Interface both servers bind; ``127.0.0.1`` (this machine only) by default,
        ``0.0.0.0`` to let a class on the same network connect.
    port : int
        HTTP port of the FastAPI app (REST API, OpenAPI docs, static page).
    viser_port : int or None
        Port of the viser GUI server; ``0`` picks a free port, ``None`` disables viser
        (REST and static page only).
    max_upload_bytes : int
        Largest accepted request body (CSV recordings, parameter sets), bytes.
    max_samples : int
        Largest number of samples of a simulated signal or an uploaded recording.
    max_operators : int
        Largest number of play operators of a model.
    max_sessions : int
        Sessions kept in memory; the least recently used one is dropped beyond it.
    teacher_token : str or None
        When set, pushing a preset to every session (``POST /api/broadcast``) needs the
        header ``X-Teacher-Token`` with this value (compared in constant time). A server
        reachable beyond loopback always has one (:meth:`with_teacher_token`).
    state_dir : str or None
        Directory of the session database (``sessions.sqlite3``); ``None`` keeps sessions
        in memory only (tests). ``hyst serve`` defaults to the per-user data directory.
    max_store_mb : int
        Size budget of the stored sessions, MB (see :mod:`app.services.storage.store`).
    max_client_store_mb : int
        MB the stored sessions created from one client address may hold together; ``0``
        (the default) is a tenth of ``max_store_mb`` (:attr:`quotas`).
    max_sessions_per_client : int
        Stored sessions one client address may have created.
    max_session_mb : int
        MB one session may hold stored (recording, fit and diagnosis).
    max_jobs : int
        Fits and diagnoses running at once (each session runs one at a time).
    allowed_hosts : tuple of str
        More names the server answers to (``Host`` header), beside the loopback names and
        ``host`` when it is not a wildcard (:attr:`host_allow_list`); ``HYST_ALLOWED_HOSTS``
        takes them comma-separated.
    trusted_proxies : tuple of str
        Addresses or networks (``127.0.0.1``, ``10.0.0.0/8``) of reverse proxies in front of
        the server. Only a request arriving from one of them has its ``X-Forwarded-For``
        read (:func:`app.services.guard.clients.client_address`); otherwise the client is the
        socket's peer. Empty by default: the header is ignored.
    max_streams_per_client : int
        Live-event streams (open pages) one client may hold at once.
    max_tabs_per_client : int
        Open viser GUI tabs (websockets) one client may hold at once.
    max_tabs : int
        Open viser GUI tabs of the whole server (each holds a view, about 5-16 MB).
    header_timeout_s, body_timeout_s : float
        Seconds a request's headers may take to arrive (from its first byte), and its body
        once the headers have; beyond, the HTTP port answers 408 and closes the connection
        (:mod:`app.connections`).
    max_connections_per_client : int
        Open connections to the HTTP port of one client address (503 beyond).
    max_connections : int
        Open connections to the HTTP port in all; ``0`` (the default) is what the
        process's file-descriptor limit leaves.
    worker_memory_mb : int
        Memory each worker process (a fit, a diagnosis, heavy figures) may allocate beyond
        what it holds at its start, MB; ``0`` (the default) is
        :func:`~app.services.jobs.worker.default_memory_limit`: twice the priced memory bound of
        a request, at most a quarter of the machine's memory, and at least what a diagnosis
        of ``max_samples`` samples needs by :data:`app.services.runs.cost.DIAGNOSE`
        (:attr:`worker_memory_bytes`). A fit or diagnosis job whose recording would need more
        is refused before it starts, in words.
    """

    host: str = "127.0.0.1"
    port: int = 8000
    viser_port: int | None = 8080
    max_upload_bytes: int = 5_000_000
    max_samples: int = 200_000
    max_operators: int = 100
    max_sessions: int = 500
    teacher_token: str | None = None
    state_dir: str | None = None
    max_store_mb: int = 1000
    max_client_store_mb: int = 0
    max_sessions_per_client: int = 500
    max_session_mb: int = 20
    max_jobs: int = 2
    allowed_hosts: tuple[str, ...] = ()
    trusted_proxies: tuple[str, ...] = ()
    max_streams_per_client: int = 8
    max_tabs_per_client: int = 8
    max_tabs: int = 300
    worker_memory_mb: int = 0
    header_timeout_s: float = 10.0
    body_timeout_s: float = 60.0
    max_connections_per_client: int = 100
    max_connections: int = 0

    def __post_init__(self) -> None:
        for name in ("max_store_mb", "max_sessions_per_client", "max_session_mb"):
            if getattr(self, name) < 1:
                raise ValueError(f"--{name.replace('_', '-')} must be at least 1, got "
                                 f"{getattr(self, name)}")
        if self.max_client_store_mb < 0:
            raise ValueError("--max-client-store-mb must be 0 (a tenth of --max-store-mb) "
                             f"or a number of MB, got {self.max_client_store_mb}")
        if not (0 < self.header_timeout_s <= 3600 and 0 < self.body_timeout_s <= 3600):
            raise ValueError("the header and body timeouts must be between 0 and 3600 s, got "
                             f"{self.header_timeout_s} and {self.body_timeout_s}")
        if self.max_connections_per_client < 1 or self.max_connections < 0:
            raise ValueError("the connection limits must be positive (max_connections 0: "
                             "from the file-descriptor limit)")
        if self.worker_memory_mb < 0:
            raise ValueError(f"the worker memory limit must be 0 (the default) or a number "
                             f"of MB, got {self.worker_memory_mb}")
        object.__setattr__(self, "trusted_proxies", proxy_networks(self.trusted_proxies))

    @classmethod
    def from_env(cls, **overrides: object) -> Settings:
        """Settings from ``HYST_<FIELD>`` environment variables, then ``overrides``."""
        kw: dict[str, object] = {}
        for f in fields(cls):
            raw = os.environ.get(f"HYST_{f.name.upper()}")
            if raw is None:
                continue
            if f.name == "allowed_hosts":
                kw[f.name] = tuple(n.strip() for n in raw.split(",") if n.strip())
            elif f.name == "trusted_proxies":
                kw[f.name] = tuple(a for a in raw.replace(",", " ").split() if a)
            elif f.name in ("host", "teacher_token", "state_dir"):
                kw[f.name] = raw
            elif f.name.endswith("_s"):
                kw[f.name] = float(raw)
            else:
                kw[f.name] = int(raw)
        kw.update({k: v for k, v in overrides.items() if v is not None})
        return cls(**kw)  # type: ignore[arg-type]

    @property
    def public(self) -> bool:
        """Whether the server is reachable beyond this machine (not a loopback address)."""
        return not is_loopback(self.host)

    def with_teacher_token(self) -> tuple[Settings, bool]:
        """These settings with a teacher token when the server is public and has none.

        Returns
        -------
        (Settings, bool)
            The settings, and whether a token was generated (``secrets.token_urlsafe``).
        """
        if self.teacher_token or not self.public:
            return self, False
        return replace(self, teacher_token=secrets.token_urlsafe(18)), True

    def teacher_ok(self, token: str | None) -> bool:
        """Whether ``token`` is the teacher token (constant-time comparison; the GUI and
        the API both use this)."""
        if not self.teacher_token or token is None:
            return False
        return hmac.compare_digest(str(token).encode("utf-8", "replace"),
                                   self.teacher_token.encode("utf-8"))

    def may_teach(self, token: str | None) -> bool:
        """Whether a request with ``token`` may push to every session: with a teacher token
        only when it matches (:meth:`teacher_ok`); without one only on a loopback server
        (a public one always has a token, :meth:`with_teacher_token`). The REST API uses
        this rule; the viser GUI needs :meth:`teacher_ok` also on loopback."""
        if self.teacher_token:
            return self.teacher_ok(token)
        return not self.public

    @property
    def host_allow_list(self) -> HostAllowList:
        """The names a request's ``Host`` may carry (see :mod:`app.services.guard.hosts`)."""
        return HostAllowList.for_server(self.host, self.allowed_hosts)

    @property
    def worker_memory_bytes(self) -> int:
        """The memory allowance of each worker process, bytes (see ``worker_memory_mb``)."""
        if self.worker_memory_mb > 0:
            return int(self.worker_memory_mb * 1e6)
        # never below what a diagnosis of the longest recording admitted needs beyond the
        # worker's start (the measured model of app.services.runs.cost: 260 MB at 200,000)
        need = DIAGNOSE.peak_bytes(self.max_samples) - WORKER_START_BYTES
        return max(default_memory_limit(self.limits.max_memory_bytes), int(need))

    @property
    def quotas(self) -> Quotas:
        """The shares of the session store of one client and one session."""
        client = self.max_client_store_mb or max(1, self.max_store_mb // 10)
        return Quotas(client_bytes=client * 1_000_000,
                      client_sessions=self.max_sessions_per_client,
                      session_bytes=self.max_session_mb * 1_000_000)

    @property
    def limits(self) -> Limits:
        """The cost limits of one request (:class:`app.services.explore.cost.Limits`)."""
        return Limits(max_operators=self.max_operators, max_samples=self.max_samples,
                      max_work=max(Limits.max_work, 125 * self.max_samples))


def is_loopback(host: str) -> bool:
    """Whether ``host`` (an address or ``localhost``) only accepts this machine's clients."""
    if host in ("localhost", ""):
        return host == "localhost"
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False
