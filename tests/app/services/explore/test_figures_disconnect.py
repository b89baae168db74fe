"""Heavy figures stop when their client hangs up (issue 18, item 3), on a real HTTP server.

``asymmetry-inverse`` with 19,000 coefficients ran past 120 s and kept a core busy after its
client left. Priced work now refuses that before any work; what is allowed but heavy (above
``KILLABLE_WORK``) runs in a worker process that the route kills once the client has gone.
Here an asymmetry map with 200 coefficients on 200,000 samples (priced 1.6e9 units, several
seconds) is asked for, the socket closed while its worker runs, and the worker must be gone
long before the work could have ended (before the change it ran in a server thread to its
end; there was no worker to find at all). No assertion is on elapsed time.
"""

from __future__ import annotations

import json
import socket
import time
import urllib.error
import urllib.request
from collections.abc import Iterator
from typing import Any

import pytest

from app.routers.schemas import SignalIn
from app.server import create_app
from app.services.explore.config import Config
from app.services.session import actions
from app.services.settings import Settings
from tests.app.job_work import wait_gone
from tests.app.live_server import serving

#: Priced at 40 x 200,000 x 201 = 1.6e9 units: a few seconds on this machine.
HEAVY_MODEL = {"type": "asymmetry", "coefficients": [1e-4] * 200, "center": 0.5, "scale": 4.0}
HEAVY_SIGNAL = {"samples": 200_000, "duration": 2.0}


@pytest.fixture(scope="module")
def server() -> Iterator[dict[str, Any]]:
    app = create_app(Settings(viser_port=None, port=0))
    with serving(app) as port:
        yield {"url": f"http://127.0.0.1:{port}/", "port": port, "app": app}


def _call(url: str, method: str = "GET", body: Any = None) -> Any:
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(url, data=data, method=method,
                                 headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=120) as r:
        return json.load(r)


def _worker(app: Any, timeout: float = 60.0) -> int:
    deadline = time.monotonic() + timeout
    while not (pids := app.state.figure_workers.pids()):
        assert time.monotonic() < deadline, "no worker process was started for heavy work"
        time.sleep(0.01)
    return pids[0]


def _hang_up_after_worker(s: dict[str, Any], method: str, path: str, body: bytes) -> int:
    sock = socket.create_connection(("127.0.0.1", s["port"]))
    sock.sendall(f"{method} {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                 f"Content-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n"
                 .encode() + body)
    pid = _worker(s["app"])
    sock.close()  # the client hangs up while its figures are computed
    return pid


def test_a_heavy_simulate_whose_client_hangs_up_is_stopped(server: dict[str, Any]) -> None:
    body = json.dumps({"model": HEAVY_MODEL, "signal": HEAVY_SIGNAL,
                       "figures": ["time"]}).encode()
    pid = _hang_up_after_worker(server, "POST", "/api/simulate", body)
    wait_gone(pid, timeout=30.0)
    # and no thread of the server computes it instead: this process (the server runs in
    # it) is idle, where the old route kept one core busy until the work ended
    cpu = time.process_time()
    time.sleep(1.0)
    assert time.process_time() - cpu < 0.5
    deadline = time.monotonic() + 10
    while server["app"].state.figure_workers.pids():
        assert time.monotonic() < deadline, "the stopped worker is still listed"
        time.sleep(0.02)


def test_heavy_session_figures_stop_and_nothing_is_stored(server: dict[str, Any]) -> None:
    web = server["url"]
    code = _call(web + "api/sessions", "POST")["code"]
    before = _call(web + f"api/sessions/{code}")
    _call(web + f"api/sessions/{code}/config", "PATCH",
          {"model": HEAVY_MODEL, "signal": HEAVY_SIGNAL})
    after_patch = _call(web + f"api/sessions/{code}")
    pid = _hang_up_after_worker(server, "GET", f"/api/sessions/{code}/figures?name=time", b"")
    wait_gone(pid, timeout=30.0)
    now = _call(web + f"api/sessions/{code}")
    assert now["version"] == after_patch["version"] != before["version"]
    assert now == after_patch  # the abandoned figures left nothing in the session


def test_heavy_figures_are_still_answered(server: dict[str, Any]) -> None:
    """A client that waits gets the same body as the in-process path computes."""
    body = {"model": {**HEAVY_MODEL, "coefficients": [1e-4] * 20},
            "signal": {"samples": 100_000}, "figures": ["time", "time"], "include_data": True}
    cfg_cost = 40 * 100_000 * 21
    assert cfg_cost > actions.KILLABLE_WORK  # so this one runs in a worker process
    got = _call(server["url"] + "api/simulate", "POST", body)
    assert list(got["figures"]) == ["time"]
    cfg = Config(model=body["model"], signal=SignalIn(samples=100_000).to_spec())
    here = actions.simulate(cfg, ["time"], Settings(viser_port=None), True)
    assert got["data"]["y"] == here["data"]["y"]
    refused = urllib.request.Request(
        server["url"] + "api/simulate", method="POST",
        data=json.dumps({**body, "model": {"type": "asymmetry", "coefficients": [1e-4] * 20,
                                           "center": 0.5, "scale": -4.0}}).encode(),
        headers={"Content-Type": "application/json"})
    with pytest.raises(urllib.error.HTTPError) as err:
        urllib.request.urlopen(refused, timeout=60)
    assert err.value.code == 422


def test_heavy_figures_wait_for_a_free_worker(server: dict[str, Any]) -> None:
    """At most ``max_running`` heavy figure workers at once (a process per request must be
    bounded as the thread pool was): with one slot, a second heavy request waits while the
    first one's worker runs, and both clients hanging up leaves no worker."""
    import asyncio

    app = server["app"]
    saved = app.state.figure_slots
    app.state.figure_slots = asyncio.Semaphore(1)
    try:
        body = json.dumps({"model": HEAVY_MODEL, "signal": HEAVY_SIGNAL,
                           "figures": ["time"]}).encode()
        first = socket.create_connection(("127.0.0.1", server["port"]))
        head = (f"POST /api/simulate HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Type: "
                f"application/json\r\nContent-Length: {len(body)}\r\n\r\n").encode()
        first.sendall(head + body)
        pid = _worker(app)
        second = socket.create_connection(("127.0.0.1", server["port"]))
        second.sendall(head + body)
        # the second one waits for the slot: never two workers at once (the first may finish
        # within the second on a fast machine, and the second then takes its place)
        deadline = time.monotonic() + 1.0
        seen = set()
        while time.monotonic() < deadline:
            pids = app.state.figure_workers.pids()
            assert len(pids) <= 1, pids
            seen.update(pids)
            time.sleep(0.01)
        assert pid in seen
        second.close()
        time.sleep(0.3)
        first.close()
        wait_gone(pid, timeout=30.0)
        deadline = time.monotonic() + 10
        while app.state.figure_workers.running():
            assert time.monotonic() < deadline, "a worker is still listed"
            time.sleep(0.02)
    finally:
        app.state.figure_slots = saved
