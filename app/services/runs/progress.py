"""Progress lines of the file-based runs: stderr for ``hyst``, a list for a batch worker."""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["Progress"]


class Progress:
    """Progress messages on stderr (``hyst fit`` can take a while); silent when ``quiet``.

    Parameters
    ----------
    command : str
        Sub-command name used as prefix.
    quiet : bool
        Suppress all messages.
    sink : callable, optional
        Receives each line instead of stderr (a batch worker keeps the messages of its own
        recording: ``lines.append``).
    """

    def __init__(self, command: str, quiet: bool = False,
                 sink: Callable[[str], object] | None = None) -> None:
        self.command = command
        self.quiet = quiet
        self.sink = sink
        self.t0 = time.perf_counter()

    def __call__(self, message: str) -> None:
        """Print ``[hyst <command> 1.2 s] message`` on stderr (or give it to ``sink``)."""
        if not self.quiet:
            dt = time.perf_counter() - self.t0
            line = f"[hyst {self.command} {dt:5.1f} s] {message}"
            if self.sink is not None:
                self.sink(line)
            else:
                print(line, file=sys.stderr, flush=True)

    @contextmanager
    def heartbeat(self, message: str, every: float = 5.0) -> Iterator[None]:
        """While the block runs, repeat ``message`` every ``every`` seconds on stderr."""
        stop = threading.Event()

        def beat() -> None:
            while not stop.wait(every):
                self(message)

        worker = threading.Thread(target=beat, daemon=True)
        if not self.quiet:
            worker.start()
        try:
            yield
        finally:
            stop.set()
            if worker.is_alive():
                worker.join()
