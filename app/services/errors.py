"""The errors the services raise with a message for the user; the interfaces translate them
(a 422, 410, 503 or a toast) and import them from here, not from :mod:`core`."""

from __future__ import annotations

from app.services.session.sessions import StoreFullError
from app.services.storage.quotas import QuotaError
from app.services.storage.store import DamagedSessionError
from core.csvio import CSVError
from core.exceptions import NotInvertibleError, ParameterError

__all__ = ["CSVError", "DamagedSessionError", "NotInvertibleError", "ParameterError",
           "QuotaError", "StoreFullError"]
