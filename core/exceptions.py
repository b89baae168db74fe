"""Exceptions and warnings of the hysteresis core.

Every exception subclasses a builtin so callers can catch ``ValueError`` without
knowing this package.
"""

from __future__ import annotations

__all__ = [
    "ClippedInputWarning",
    "FitWarning",
    "HysteresisError",
    "NotFittedError",
    "NotInvertibleError",
    "ParameterError",
    "UnsupportedOptionError",
]


class HysteresisError(Exception):
    """Base class of every error raised on purpose by this package."""


class ParameterError(HysteresisError, ValueError):
    """A parameter or input violates a rule; the message names both."""


class UnsupportedOptionError(ParameterError):
    """A valid option that this estimator (fit kind) cannot use; the message says which
    values it can use."""


class NotInvertibleError(HysteresisError, ValueError):
    """The model has no (analytical) inverse; the message names the offending slope."""


class NotFittedError(HysteresisError, ValueError, AttributeError):
    """An estimator was used before ``fit``."""


class FitWarning(UserWarning):
    """A fit finished but something about it deserves attention."""


class ClippedInputWarning(UserWarning):
    """An input left the domain of an inverse and was clipped to it."""
