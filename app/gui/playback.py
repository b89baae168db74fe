"""Playback of the digitized states: one daemon thread per tab, stoppable at any step."""

from __future__ import annotations

import threading
from collections.abc import Callable

__all__ = ["MIN_SPEED", "Playback"]

#: Slowest playback, states per second (the speed slider's minimum).
MIN_SPEED = 0.25


class Playback:
    """Step through ``rows`` states at a speed read before every step.

    Parameters
    ----------
    speed : callable
        Returns the current speed, states per second (read at every step, so a speed
        slider acts during playback).
    on_step : callable
        Called with the state index ``k`` (0, 1, …, rows - 1) from the playback thread.
    """

    def __init__(self, speed: Callable[[], float], on_step: Callable[[int], None]) -> None:
        self._speed = speed
        self._on_step = on_step
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self, rows: int) -> None:
        """Play states ``0 … rows - 1`` from the start (stopping a playback that runs)."""
        self.stop()
        if self._thread is not None:
            self._thread.join(timeout=1)
        self._stop = stop = threading.Event()

        def play() -> None:
            for k in range(rows):
                if stop.wait(1.0 / max(MIN_SPEED, float(self._speed()))):
                    return
                self._on_step(k)

        self._thread = threading.Thread(target=play, daemon=True, name="play")
        self._thread.start()

    def stop(self) -> None:
        """Stop at the next step (no-op when nothing plays)."""
        self._stop.set()

    @property
    def playing(self) -> bool:
        """Whether a playback thread runs."""
        return self._thread is not None and self._thread.is_alive() and not self._stop.is_set()
