"""An uploaded file checked before it is read: its size, then its first bytes.

The web page makes these checks in the browser before it sends a file (``static/upload.js``:
``refused``); viser's upload button sends every file it is given, so the viser interface
makes the same checks on what its client declares and on the first part that arrives
(:func:`app.gui.viser_guard.bound_uploads`), before any of the file is kept or parsed. The
words are the web page's, character for character (``tests/e2e/test_viser_upload_check.py``
compares the two pages' messages for the same files).
"""

from __future__ import annotations

from decimal import ROUND_HALF_UP, Decimal

__all__ = ["HEAD_BYTES", "not_text", "over_text", "size_text", "too_large"]

#: How many of a file's first bytes are looked at (as the web page: ``file.slice(0, 4096)``).
HEAD_BYTES = 4096

#: What a file that is not CSV text starts with, in words (the web page's ``MAGIC``).
_MAGIC: tuple[tuple[bytes, str], ...] = (
    (b"\x89PNG", "a PNG image"), (b"\xff\xd8\xff", "a JPEG image"),
    (b"GIF8", "a GIF image"), (b"%PDF", "a PDF document"),
    (b"PK\x03\x04", "a ZIP archive or an Excel .xlsx workbook"),
    (b"\xd0\xcf\x11\xe0", "an old Excel .xls or Word file"),
)


def size_text(n: int) -> str:
    """A file size in words as the web page writes it: ``5.1 MB`` from a million bytes up
    (one decimal, halves rounded up as JavaScript's ``toFixed``), else whole kB rounded up.

    Parameters
    ----------
    n : int
        Size, bytes (>= 0).
    """
    if n >= 1_000_000:
        mb = Decimal(n / 1e6).quantize(Decimal("0.1"), rounding=ROUND_HALF_UP)
        return f"{mb} MB"
    return f"{-(-n // 1000)} kB"


def over_text(n: int, limit: int) -> str:
    """The size ``n`` of a file over ``limit`` in words: :func:`size_text`, finer where that
    reads the same as the limit's (``5.03 MB`` beside ``5.0 MB``; below a megabyte, bytes),
    as the web page's ``over``."""
    if size_text(n) != size_text(limit):
        return size_text(n)
    if n >= 1_000_000:
        mb = Decimal(n / 1e6).quantize(Decimal("0.01"), rounding=ROUND_HALF_UP)
        return f"{mb} MB"
    return f"{n:,} bytes"


def too_large(name: str, size: int, limit: int) -> str | None:
    """Why a CSV file of ``size`` bytes is refused by its size (more than ``limit``), in
    words, or ``None`` when it may be sent.

    Parameters
    ----------
    name : str
        The file's name as the user chose it.
    size, limit : int
        The file's size and the largest upload taken (``Settings.max_upload_bytes``),
        bytes.
    """
    if size <= limit:
        return None
    return (f"{name} is {over_text(size, limit)}, more than the {size_text(limit)} this explorer "
            "takes. Upload a shorter stretch of the recording (fewer rows) or only the time, "
            "input and output columns.")


def _what(head: bytes) -> str | None:
    for magic, what in _MAGIC:
        if head.startswith(magic):
            return what
    utf16 = head[:2] in (b"\xff\xfe", b"\xfe\xff")
    return "a binary file, not text" if not utf16 and b"\x00" in head else None


def not_text(name: str, head: bytes) -> str | None:
    """Why a file whose first bytes are ``head`` is not a CSV text file (an image, a
    workbook, NUL bytes without a UTF-16 mark), in words, or ``None``.

    Parameters
    ----------
    name : str
        The file's name as the user chose it.
    head : bytes
        The file's first bytes (only the first :data:`HEAD_BYTES` are looked at).
    """
    what = _what(bytes(head[:HEAD_BYTES]))
    if what is None:
        return None
    return (f"{name} is not a CSV text file: it looks like {what}. Save the measurement as "
            "CSV (comma-separated text, one row per sample, e.g. \"Save as: CSV\" in a "
            "spreadsheet) and upload that file.")
