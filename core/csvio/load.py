"""Which reader reads a source: the whole text, or a large numeric file in blocks."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from . import stream
from .errors import CSVError
from .options import MAX_BYTES, CsvOptions
from .source import CSVText, Source
from .table import CSVLayout, Table, read_table_whole

__all__ = ["inspect_csv", "inspect_csv_text", "read_table"]


def read_table(source: Source, opts: CsvOptions, min_columns: int = 2) -> tuple[Table, str]:
    """The table of ``source`` read with the layout options of ``opts``, and the file stem.

    A file larger than :data:`~core.csvio.stream.STREAM_FROM_BYTES` is read in blocks
    (:func:`~core.csvio.stream.read_streamed`: the numbers, not the text, are kept) when it
    is a numeric table; otherwise, and for content, the whole text is read
    (:func:`read_table_whole`) within ``max_bytes`` / ``max_rows`` (default
    :data:`~core.csvio.options.MAX_BYTES` / :data:`~core.csvio.options.MAX_ROWS`). A file in
    blocks has no size limit but the memory its numbers need, checked before they are read.
    Parameters and results as for :func:`read_table_whole`.
    """
    path = _file_path(source)
    if path is not None:
        size = path.stat().st_size
        whole = MAX_BYTES if opts.max_bytes is None else opts.max_bytes
        if size > stream.STREAM_FROM_BYTES and (opts.max_bytes is None or size <= whole):
            try:
                return stream.read_streamed(path, size, opts, min_columns), path.stem
            except stream.NotStreamable as why:
                if size > whole:
                    raise stream.refusal(str(path), size, whole, why) from None
            except stream.MemoryRefusal:
                raise
            except CSVError:
                if size > whole:
                    raise
                # within the whole-text limits: the whole-text reader says it, as always
    return read_table_whole(source, opts, min_columns)


def _file_path(source: Source) -> Path | None:
    """``source`` as the path of a regular file, or None (content, streams, no such file)."""
    if isinstance(source, str) and ("\n" in source or "\r" in source):
        return None
    if not isinstance(source, (str, os.PathLike)):
        return None
    path = Path(source)
    return path if path.is_file() else None


def inspect_csv(source: Source, options: CsvOptions | None = None, *, min_columns: int = 2,
                **changes: Any) -> CSVLayout:
    """Work out the layout of a CSV without converting it (for previews and pickers).

    Parameters
    ----------
    source : path, str, bytes, open file or CSVText
        As for :func:`~core.csvio.read_csv`.
    options : CsvOptions, optional
        Reading options; only the layout ones (``delimiter``, ``decimal``, ``header``,
        ``skiprows``, ``encoding``, ``max_bytes``, ``max_rows``) matter here.
    min_columns : int
        Fewest columns the table must have: 2 for recordings (input and output, the
        default), 1 for input-only signals (see :func:`~core.csvio.read_input`).
    **changes
        Fields of :class:`~core.csvio.CsvOptions` that replace those of ``options``.

    Returns
    -------
    CSVLayout
        Delimiter, decimal mark, header, columns with units, number of rows.
    """
    opts = CsvOptions.of(options, **changes)
    return read_table(source, opts, min_columns)[0].layout


def inspect_csv_text(content: str | bytes, options: CsvOptions | None = None, *,
                     name: str = "<text>", **changes: Any) -> CSVLayout:
    """:func:`inspect_csv` of CSV *content* (never a file name); see
    :func:`~core.csvio.read_csv_text`."""
    return inspect_csv(CSVText(content, name), options, **changes)
