"""An app served by a real uvicorn server on a free port, in a thread of the test process
(for tests that need real sockets: a client that hangs up, worker processes to find)."""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterator
from typing import Any


@contextlib.contextmanager
def serving(app: Any, timeout: float = 60.0, **config: Any) -> Iterator[int]:
    """Serve ``app`` on 127.0.0.1 while the block runs (``config``: more
    ``uvicorn.Config`` arguments); yields the port."""
    import uvicorn

    srv = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=0, log_level="warning",
                                        **config))
    th = threading.Thread(target=srv.run, daemon=True)
    th.start()
    deadline = time.monotonic() + timeout
    while not srv.started:
        assert time.monotonic() < deadline and th.is_alive(), "the server did not start"
        time.sleep(0.05)
    try:
        yield srv.servers[0].sockets[0].getsockname()[1]
    finally:
        srv.should_exit = True
        th.join(timeout=20)
