"""The reader's exceptions: :class:`CSVError` (what, where, what to do) and its uneven-time case."""

from __future__ import annotations

from typing import Any

from ..exceptions import ParameterError

__all__ = ["CSVError", "UnevenTimeError"]


class CSVError(ParameterError):
    """A CSV recording cannot be read as asked; the message says what, where and what to do.

    Attributes
    ----------
    source : str
        File path, ``"<text>"`` or ``"<bytes>"``.
    line : int or None
        1-based line of the problem in the file, when there is one.
    column : str or None
        Column name (or ``"column 3"``) of the problem, when there is one.
    column_index : int or None
        0-based index of that column, when known.
    """

    def __init__(
        self, message: str, *, source: str = "", line: int | None = None,
        column: str | None = None, column_index: int | None = None,
    ) -> None:
        super().__init__(message)
        self.source = source
        self.line = line
        self.column = column
        self.column_index = column_index


class TimeOrderError(CSVError):
    """The chosen time column does not strictly increase (a duplicated or decreasing time
    stamp): a caller that reads several runs as one recording tells runs that each restart
    their clock by this class, not by the message."""


class UnevenTimeError(CSVError):
    """The time stamps of a recording are unevenly spaced and no choice was made.

    Raised by :func:`read_csv` (and :func:`read_input`) without ``resample`` when
    ``uneven="error"``; a caller that offers the choice (resample or keep) reads the
    spacing from the attributes instead of the message.

    Attributes
    ----------
    spacing_min, spacing_max, spacing_mean, spacing_median : float
        Smallest, largest, mean and median spacing of the time stamps, in s (the median
        is the spacing ``resample=True`` interpolates onto).
    """

    def __init__(self, message: str, *, spacing: tuple[float, float, float, float],
                 **kwargs: Any) -> None:
        super().__init__(message, **kwargs)
        self.spacing_min, self.spacing_max, self.spacing_mean, self.spacing_median = (
            float(x) for x in spacing)
