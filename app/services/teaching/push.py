"""The teacher's push: a model and/or an input signal to every session used in the last
hour, then an event to every open page (no web imports).

It sits with the class (a lesson's every move is a push, :mod:`.lessons`), above the
sessions it changes: :mod:`app.services.session` imports nothing of :mod:`app.services.teaching`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from app.services.explore.config import Config, SignalSpec
from app.services.session.sessions import SessionRegistry
from app.services.teaching.events import HUB, PushNote
from core.exceptions import ParameterError

__all__ = ["push"]


def push(registry: SessionRegistry, *, model: dict[str, Any] | None = None,
         signal: SignalSpec | None = None, note: PushNote | None = None,
         mismatch: float | None = None) -> tuple[int, int]:
    """The teacher's push: ``model`` and/or ``signal`` (and a lesson step's ``mismatch``)
    to every session used in the last hour (each committed, so a reload or a restart keeps
    it), then the event ``{"kind": "push", **note}`` to every open page. Returns
    ``(sessions changed, pages told)``.

    Raises
    ------
    ParameterError
        If there is nothing to push.
    """
    if model is None and signal is None:
        raise ParameterError("choose a preset or an input signal to push")

    def change(cfg: Config) -> Config:
        new = cfg if model is None else cfg.with_model(model)
        if mismatch is not None:
            new = replace(new, mismatch=mismatch)
        return new if signal is None else replace(new, signal=signal, use_recording=False)

    n = registry.update_recent(change)
    return n, HUB.broadcast({"kind": "push", **(note or {})})
