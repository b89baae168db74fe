"""One byte budget for the caches of a diagnosis, derived from its memory target (issue 31).

A diagnosis keeps play banks, their level segments, projections on reduced bases, Bouc-Wen
banks of a history search and memoised fits, so that its searches do not recompute what they
meet again. Together they may hold :func:`cache_budget` bytes: what issue 31's target (peak
resident memory <= 400 MB + 0.3 kB per sample) leaves after what the diagnosis holds at its
peak with no cache at all. :class:`CacheBudget` keeps the account: an entry that does not fit
pushes out the least valuable entries first (derived arrays, then banks, then fits), the
least recently used first within each, and room is made before a new array is formed, so
the caches and the array being formed never hold more than the budget together.
"""

from __future__ import annotations

import threading
from collections import OrderedDict
from typing import Any

__all__ = ["CacheBudget", "cache_budget", "DERIVED", "BANK", "FIT"]

#: Issue 31's memory target of a diagnosis: peak resident bytes <= TARGET_BASE +
#: TARGET_PER_SAMPLE * samples (all recordings together).
TARGET_BASE = 400e6
TARGET_PER_SAMPLE = 300.0
#: What a diagnosis holds at its peak with no cache beyond the 4 most recent fits (the
#: imports, the recordings, the working arrays of one fit and of the residual maps): an
#: upper envelope of ``hyst diagnose FILE --json`` peaks measured with the caches off
#: (one thread, ``/usr/bin/time``; tilings of the shipped piezo recording, main e298abf):
#: 265 / 286 / 349 / 452 / 514 MB at 25k / 50k / 100k / 400k / 1M samples, 828 MB at 2M
#: and 2,954 MB at 10M (docs/pages/diagnose.md, "Scale").
NEED_BASE = 350e6
NEED_PER_SAMPLE = 265.0

#: Ranks of value (what an entry costs to form again, per byte), lowest pushed out first:
#: arrays formed from a bank in one pass (level segments, projections), banks (a pass of
#: the operators over the input), memoised fits (a whole structure fit).
DERIVED, BANK, FIT = 0, 1, 2


def cache_budget(n_samples: int) -> float:
    """Bytes the caches of a diagnosis of ``n_samples`` samples may hold together: the memory
    target less what the diagnosis needs without caches (:data:`NEED_BASE`,
    :data:`NEED_PER_SAMPLE`), never negative. 52 MB at 50,000 samples, 64 MB at 400,000,
    400 MB at 10 million (where a bank of 100 plays, 8 GB, fits nowhere)."""
    n = max(0, int(n_samples))
    return max(0.0, TARGET_BASE - NEED_BASE + (TARGET_PER_SAMPLE - NEED_PER_SAMPLE) * n)


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
