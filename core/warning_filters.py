"""One re-entrant lock for the process-wide warning filters.

``warnings.catch_warnings`` swaps the warning filters of the whole process (before Python
3.14), and restores, on exit, what it saw on entry. Two threads that each enter one can
therefore restore each other's filters: a fit recording its warnings in one thread then
misses them, or, under a test runner that turns warnings into errors, another thread's
warning is raised. Every block of ``core`` that changes the filters holds :data:`FILTERS`
(re-entrant: a fit that silences its own sub-fits nests), so such blocks take turns.
"""

from __future__ import annotations

import threading

__all__ = ["FILTERS"]

#: Held around every ``warnings.catch_warnings`` block in ``core``.
FILTERS = threading.RLock()
