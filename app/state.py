"""Where older code imports the explorer's session types from: a re-export only.

The session state and its transitions live in the service layer: the config in
:mod:`app.services.config`, the one typed state in :mod:`app.services.store`
(:class:`~app.services.store.SessionState`), live sessions and the registry in
:mod:`app.services.sessions`, and what the routers, the GUI and the command line call in
:mod:`app.services.actions`. New code imports from there.
"""

from __future__ import annotations

from .services.config import EXAMPLE1, Config, SignalSpec, config_from_dict
from .services.sessions import (
    CODE_ALPHABET,
    CODE_LENGTH,
    Listener,
    Session,
    SessionRegistry,
    StoreFullError,
    new_code,
    normalise_code,
)

__all__ = [
    "CODE_ALPHABET",
    "CODE_LENGTH",
    "EXAMPLE1",
    "Config",
    "Listener",
    "Session",
    "SessionRegistry",
    "SignalSpec",
    "StoreFullError",
    "config_from_dict",
    "new_code",
    "normalise_code",
]
