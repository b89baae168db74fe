"""The memory this process may still take, for checks made before a large piece of work."""

from __future__ import annotations

import resource
from pathlib import Path

__all__ = ["available_memory"]


def available_memory() -> int | None:
    """Bytes this process may still take, or ``None`` where nothing says.

    The smallest of: the memory the machine has available now (``MemAvailable`` of
    ``/proc/meminfo``), this process's address-space and data-segment limits
    (``RLIMIT_AS``, ``RLIMIT_DATA``: what a job worker sets on itself), less what the process
    already holds of them, and its control group's limit less its usage.

    Returns
    -------
    int or None
        Bytes; ``None`` when none of them is known (not Linux).
    """
    caps: list[int] = []
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    caps.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    held = _held()
    for lim in (resource.RLIMIT_AS, resource.RLIMIT_DATA):
        soft = resource.getrlimit(lim)[0]
        if soft != resource.RLIM_INFINITY:
            caps.append(max(0, int(soft) - held.get(lim, 0)))
    try:
        top = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = Path("/sys/fs/cgroup/memory.current").read_text().strip()
        if top != "max":
            caps.append(int(top) - int(used))
    except (OSError, ValueError):
        pass
    return min(caps) if caps else None


def _held() -> dict[int, int]:
    """What this process holds of its address-space and data limits (bytes), from
    ``/proc/self/status`` (``VmSize``, ``VmData``); empty where unknown."""
    out: dict[int, int] = {}
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                key = line.split(":", 1)[0]
                if key == "VmSize":
                    out[resource.RLIMIT_AS] = int(line.split()[1]) * 1024
                elif key == "VmData":
                    out[resource.RLIMIT_DATA] = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return out
