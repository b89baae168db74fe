"""One byte budget for the caches of a diagnosis, derived from its memory target (issue 31).

A diagnosis keeps play banks, their level segments, projections on reduced bases, Bouc-Wen
banks of a history search and memoised fits, so that its searches do not recompute what they
meet again. Together they may hold :func:`cache_budget` bytes: what issue 31's target (peak
resident memory <= 400 MB + 0.3 kB per sample) leaves after what the process holds when the
diagnosis starts (measured) and what the diagnosis adds at its peak with no cache at all.
:class:`CacheBudget` keeps the account: an entry that does not fit pushes out the least
valuable entries first (derived arrays, then banks, then fits), the least recently used
first within each, and room is made before a new array is formed, so the caches and the
array being formed never hold more than the budget together.
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from typing import Any

__all__ = ["CacheBudget", "cache_budget", "resident_bytes", "DERIVED", "BANK", "FIT"]

#: Issue 31's memory target of a diagnosis: peak resident bytes <= TARGET_BASE +
#: TARGET_PER_SAMPLE * samples (all recordings together).
TARGET_BASE = 400e6
TARGET_PER_SAMPLE = 300.0
#: What a diagnosis adds, at its peak with no cache beyond the fit memo's 4 most recent
#: fits, to what its process holds when it starts (the imports, the recordings read): an
#: upper envelope of ``hyst diagnose FILE --json`` peaks with the caches off less the
#: resident memory when the diagnosis started (one thread, ``/usr/bin/time``; tilings of the
#: shipped piezo recording, main b9acf70 with numpy 2.4.6, scipy 1.17.1, numba 0.68.1):
#: 117 / 177 / 259 / 273 MB at 25k / 100k / 400k / 1M samples over 209 / 224 / 251 / 315 MB
#: resident at the start (docs/pages/diagnose.md, "Scale", round 5). The resident part is
#: measured, not modelled: it depends on the libraries' versions (round 4's model, 350 MB +
#: 0.265 kB per sample in all, was exceeded by 52-58 MB on a newer set of the same libraries).
WORK_BASE = 150e6
WORK_PER_SAMPLE = 300.0
#: The resident memory assumed where the process's own cannot be read (round 4's measured
#: imports and recordings: its whole no-cache model less the work above, at 50,000 samples).
RESIDENT_FALLBACK = 200e6

#: Ranks of value (what an entry costs to form again, per byte), lowest pushed out first:
#: arrays formed from a bank in one pass (level segments, projections), banks (a pass of
#: the operators over the input), memoised fits (a whole structure fit).
DERIVED, BANK, FIT = 0, 1, 2


def resident_bytes() -> float | None:
    """Resident memory of this process now (bytes, ``/proc/self/statm``), ``None`` where it
    cannot be read (not Linux)."""
    try:
        with open("/proc/self/statm", encoding="ascii") as fh:
            pages = int(fh.read().split()[1])
        return float(pages * os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, IndexError):
        return None


def cache_budget(n_samples: int, resident: float | None = None) -> float:
    """Bytes the caches of a diagnosis of ``n_samples`` samples may hold together: the memory
    target less what the process holds when the diagnosis starts (``resident``, bytes;
    default :func:`resident_bytes` now) and what the diagnosis adds without caches
    (:data:`WORK_BASE`, :data:`WORK_PER_SAMPLE`), never negative. With the command line's
    210-320 MB resident at the start: about 40 MB at 25,000 samples, 25 MB at 100,000, none
    from about 400,000 on (where the streamed fits need no bank kept)."""
    n = max(0, int(n_samples))
    if resident is None:
        resident = resident_bytes()
    if resident is None:
        resident = RESIDENT_FALLBACK
    return max(0.0, TARGET_BASE + TARGET_PER_SAMPLE * n - resident
               - WORK_BASE - WORK_PER_SAMPLE * n)


class CacheBudget:
    """The byte account of several caches (dicts) sharing one limit.

    Each entry is registered with its store (the dict holding it), key, size in bytes and
    rank of value (:data:`DERIVED`, :data:`BANK`, :data:`FIT`). When an entry must make
    room, the least recently used entry of the lowest rank goes first (from whichever store
    holds it). ``floor[store]``: that many most recent entries of a store are never pushed
    out by bytes (the fit memo's most recent fits, part of what a diagnosis needs anyway);
    their bytes still count. The stores are plain dicts: :meth:`get` moves a hit to the
    end of its store and of the account.

    Parameters
    ----------
    limit : float
        Bytes the entries may hold together.
    """

    def __init__(self, limit: float) -> None:
        self.limit = float(limit)
        #: bytes held by the registered entries
        self.used = 0.0
        #: per rank, (id(store), key) -> (store, key, size), oldest first
        self._ranks: dict[int, OrderedDict] = {DERIVED: OrderedDict(), BANK: OrderedDict(),
                                               FIT: OrderedDict()}
        self._rank_of: dict[tuple[int, Any], int] = {}
        self.floor: dict[int, int] = {}
        self._lock = threading.RLock()

    def get(self, store: dict, key: Any) -> Any:
        """``store.get(key)``, marking a hit as most recently used."""
        with self._lock:
            v = store.pop(key, None)
            if v is not None:
                store[key] = v
                rank = self._rank_of.get((id(store), key))
                if rank is not None:
                    self._ranks[rank].move_to_end((id(store), key))
            return v

    def fits(self, size: float) -> bool:
        """Whether an entry of ``size`` bytes can be kept at all."""
        return size <= self.limit

    def make_room(self, size: float, into: dict | None = None) -> bool:
        """Push out entries (lowest rank, least recently used first) until ``size`` more
        bytes fit; False (and nothing pushed out) when ``size`` exceeds the whole limit.
        Called before a new array is formed, so the caches and the new array together stay
        within the limit. ``into``: the store the new entry goes to (one entry fewer of its
        floor is kept for it)."""
        with self._lock:
            if size > self.limit:
                return False
            for rank in (DERIVED, BANK, FIT):
                if self.used + size <= self.limit:
                    break
                entries = self._ranks[rank]
                for ik in list(entries):
                    if self.used + size <= self.limit:
                        break
                    store, key, _ = entries[ik]
                    if self._floored(store, key, into):
                        continue
                    self.drop(store, key)
            return self.used + size <= self.limit

    def put(self, store: dict, key: Any, value: Any, size: float, rank: int,
            count: int | None = None) -> bool:
        """Keep ``store[key] = value`` (``size`` bytes, rank ``rank``), pushing out what must
        go: the oldest entries of ``store`` beyond ``count`` entries, then by bytes
        (:meth:`make_room`). Returns whether it was kept: an entry that does not fit is not,
        unless its store has a floor (then its oldest entries go down to the floor and it is
        kept, over the limit if need be)."""
        with self._lock:
            self.drop(store, key)
            if count is not None:
                while len(store) >= count:
                    self.drop(store, next(iter(store)))
            if not self.make_room(size, into=store):
                floor = self.floor.get(id(store), 0)
                if floor <= 0:
                    return False
                while len(store) >= floor:
                    self.drop(store, next(iter(store)))
            store[key] = value
            self._ranks[rank][(id(store), key)] = (store, key, size)
            self._rank_of[(id(store), key)] = rank
            self.used += size
            return True

    def drop(self, store: dict, key: Any) -> None:
        """Remove ``store[key]`` and its bytes from the account (nothing if absent)."""
        with self._lock:
            store.pop(key, None)
            rank = self._rank_of.pop((id(store), key), None)
            if rank is not None:
                self.used -= self._ranks[rank].pop((id(store), key))[2]

    def _floored(self, store: dict, key: Any, into: dict | None = None) -> bool:
        """Whether ``key`` is among the ``floor`` most recent entries of ``store`` (one fewer
        when a new entry is going ``into`` it)."""
        floor = self.floor.get(id(store), 0) - (store is into)
        if floor <= 0:
            return False
        keys = list(store)
        return key in keys[-floor:]
