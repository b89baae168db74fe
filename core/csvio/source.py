"""Bytes to text: where the CSV comes from (path, content, stream), size limits, encoding."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from .errors import CSVError

__all__ = ["CSVText", "Source", "decode_text", "load_bytes"]


@dataclass(frozen=True)
class CSVText:
    """CSV content that is read as content, never as a file name (e.g. an upload).

    Parameters
    ----------
    content : str or bytes
        The CSV text, or its bytes (the encoding is then detected as for a file).
    name : str
        Label used in messages, ``"<text>"`` by default.
    """

    content: str | bytes
    name: str = "<text>"


Source = str | os.PathLike[str] | bytes | bytearray | IO[str] | IO[bytes] | CSVText



#: Control characters that no text CSV holds (tab, line breaks, form feed and vertical tab
#: are allowed).
_CONTROL_CHARS = re.compile(r"[\x00-\x08\x0e-\x1f\x7f]")
_CONTROL_BYTES = re.compile(rb"[\x00-\x08\x0e-\x1f\x7f]")


def load_bytes(source: Source, max_bytes: int) -> tuple[bytes | str, str, str]:
    """Return ``(content, label, stem)``."""
    too_big = (
        "{label} is {size:,} bytes, more than max_bytes={mb:,}; pass a larger max_bytes= to "
        "read it anyway, or cut / decimate the recording first"
    )
    if isinstance(source, CSVText):
        content = source.content
        if not isinstance(content, (str, bytes, bytearray)):
            raise CSVError(f"CSV content must be str or bytes, not {type(content).__name__}")
        if len(content) > max_bytes:
            raise CSVError(too_big.format(label=source.name, size=len(content), mb=max_bytes),
                           source=source.name)
        data = content if isinstance(content, str) else bytes(content)
        return data, source.name, "recording"
    if isinstance(source, (bytes, bytearray)):
        label = "<bytes>"
        if len(source) > max_bytes:
            raise CSVError(too_big.format(label=label, size=len(source), mb=max_bytes),
                           source=label)
        return bytes(source), label, "recording"
    if hasattr(source, "read"):
        label = str(getattr(source, "name", "<stream>"))
        data = source.read(max_bytes + 1)
        if len(data) > max_bytes:
            raise CSVError(f"{label} is more than max_bytes={max_bytes:,} bytes; pass a "
                           "larger max_bytes= to read it anyway", source=label)
        return data, label, Path(label).stem if label != "<stream>" else "recording"
    if isinstance(source, str) and ("\n" in source or "\r" in source):
        label = "<text>"
        if len(source) > max_bytes:
            raise CSVError(too_big.format(label=label, size=len(source), mb=max_bytes),
                           source=label)
        return source, label, "recording"
    if not isinstance(source, (str, os.PathLike)):
        raise CSVError(
            f"cannot read a CSV from a {type(source).__name__}; pass a path, the CSV text "
            "(a str with newlines), bytes, or an open file"
        )
    path = Path(source)
    label = str(path)
    if not path.is_file():
        hint = (
            "; to parse CSV text pass a string that contains newlines"
            if isinstance(source, str) else ""
        )
        raise CSVError(f"{label}: no such file{hint}", source=label)
    size = path.stat().st_size
    if size > max_bytes:
        raise CSVError(too_big.format(label=label, size=size, mb=max_bytes), source=label)
    return path.read_bytes(), label, path.stem


def _line_of_offset(data: bytes, offset: int) -> int:
    return data.count(b"\n", 0, offset) + 1


def _decode_utf16(data: bytes, label: str) -> str:
    """``data`` (UTF-16 with its BOM) as text; a lone surrogate or a cut-off last character
    is a :class:`CSVError` naming its line."""
    try:
        return data.decode("utf-16")
    except UnicodeDecodeError as exc:
        start = exc.start  # a byte offset into data, the BOM included
        before = data[:start - (start % 2)].decode("utf-16", errors="replace")
        line = before.count("\n") + 1
        what = ("an unpaired surrogate" if "surrogate" in exc.reason
                else "a character cut off at the end of the file")
        raise CSVError(
            f"{label} is not valid UTF-16: {what} at byte {start} (line {line}); save the "
            "recording again as UTF-8 or UTF-16 text",
            source=label, line=line,
        ) from exc


def decode_text(data: bytes | str, encoding: str | None, label: str) -> tuple[str, str, list[str]]:
    """Return ``(text, encoding, notes)``; reject binary content."""
    notes: list[str] = []
    if isinstance(data, str):
        text, enc = data, "str"
    else:
        if len(data) == 0:
            raise CSVError(
                f"{label}: the file is empty (0 bytes); export the recording again",
                source=label,
            )
        if encoding is not None:
            try:
                text, enc = data.decode(encoding), encoding
            except (UnicodeDecodeError, LookupError) as exc:
                raise CSVError(
                    f"{label} cannot be decoded as {encoding}: {exc}; leave encoding=None "
                    "to detect it", source=label
                ) from exc
        elif data[:2] in (b"\xff\xfe", b"\xfe\xff"):
            text, enc = _decode_utf16(data, label), "utf-16"
        else:
            nul = data.find(b"\x00")
            if nul >= 0:
                line = _line_of_offset(data, nul)
                raise CSVError(
                    f"{label} is not a text CSV: NUL byte at byte offset {nul} (line {line}); "
                    "it looks like a binary file (e.g. a .tdms/.mat/.xlsx); export the "
                    "recording as CSV text",
                    source=label, line=line,
                )
            try:
                text, enc = data.decode("utf-8-sig"), "utf-8"
            except UnicodeDecodeError as exc:
                line = _line_of_offset(data, exc.start)
                text, enc = data.decode("latin-1"), "latin-1"
                notes.append(
                    f"decoded as Latin-1: not valid UTF-8 at byte {exc.start} (line {line})"
                )
    text = text.lstrip("\ufeff")
    if isinstance(data, bytes) and enc in ("utf-8", "latin-1"):
        # control bytes < 0x80 are the same characters in UTF-8 and Latin-1: check the bytes
        # (a regular expression over them allocates nothing; comparisons of a numpy view
        # took four bytes of temporaries per byte of the file)
        hit = _CONTROL_BYTES.search(data)
        ctrl_char = chr(data[hit.start()]) if hit else ""
        line = _line_of_offset(data, hit.start()) if hit else 0
    else:
        m = _CONTROL_CHARS.search(text)
        ctrl_char = m.group() if m else ""
        line = text.count("\n", 0, m.start()) + 1 if m else 0
    if ctrl_char:
        raise CSVError(
            f"{label} is not a text CSV: control character {ctrl_char!r} on line {line}; "
            "it looks like binary data; export the recording as CSV text",
            source=label, line=line,
        )
    return text, enc, notes
