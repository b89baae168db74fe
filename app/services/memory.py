"""Giving freed memory back to the operating system (no web imports).

Parsing a 5 MB CSV allocates a few times its size in short-lived Python objects and arrays;
glibc's allocator keeps the freed space in its arenas (one per thread that allocated), so
30 concurrent uploads left the server about 0.7 GB larger for good (issue 35 item 7).
:func:`give_back` asks glibc to return the free pages (``malloc_trim``) after such a parse;
elsewhere it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import threading

__all__ = ["give_back"]

_lock = threading.Lock()
_trim = None
_looked = False


def give_back() -> bool:
    """Return the allocator's free memory to the system (glibc ``malloc_trim(0)``).

    Returns
    -------
    bool
        Whether anything could be asked (``False`` without glibc).
    """
    global _trim, _looked
    with _lock:
        if not _looked:
            _looked = True
            try:
                libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
                _trim = libc.malloc_trim
                _trim.argtypes = [ctypes.c_size_t]
                _trim.restype = ctypes.c_int
            except (OSError, AttributeError):
                _trim = None
        trim = _trim
    if trim is None:
        return False
    trim(0)
    return True
