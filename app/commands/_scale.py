"""What a long recording will cost ``hyst diagnose``: samples counted before reading, peak
memory and CPU time from measured per-sample models, the memory this process may use, and
progress lines with the time left.

The models (:mod:`app.services.runs.cost`, shared with the batch and job workers) are lines
above the measurements of ``benchmarks/bench_diagnose_scale.py`` (tiled piezo recordings, one
thread; the table is in ``docs/pages/diagnose.md``, "Scale").
"""

from __future__ import annotations

import re
import resource
import time
from collections.abc import Callable, Sequence
from pathlib import Path

from app.services.runs.cost import (
    DIAGNOSE,
    ETA_FROM_S,
    FIT,
    CostModel,
    memory_refusal,
    time_left_text,
)
from app.services.runs.inputs import CommandError
from app.services.runs.progress import Progress

__all__ = ["DIAGNOSE", "ETA_FROM_S", "FIT", "CostModel", "EtaProgress", "allowed_memory",
           "check_memory", "count_samples"]


def count_samples(files: Sequence[str | Path], chunk: int = 1 << 22) -> int:
    """Lines of ``files`` (an upper bound on their samples: a header and notes are lines
    too), counted in chunks of ``chunk`` bytes without parsing; 0 for a file that cannot be
    opened or is not a regular file (a device or a pipe could be endless; the reader then
    says why)."""
    total = 0
    for f in files:
        try:
            if not Path(f).is_file():
                continue
            with open(f, "rb") as fh:
                last = b"\n"
                while block := fh.read(chunk):
                    total += block.count(b"\n")
                    last = block[-1:]
                total += last != b"\n"  # a last line without its line break
        except OSError:
            continue
    return total


def allowed_memory() -> int | None:
    """Bytes this process may still take: the memory the machine has available now
    (``MemAvailable``), within this process's address-space / data limits and its control
    group's limit; ``None`` where none of them is known."""
    caps: list[int] = []
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    caps.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    for lim in (resource.RLIMIT_AS, resource.RLIMIT_DATA):
        soft = resource.getrlimit(lim)[0]
        if soft != resource.RLIM_INFINITY:
            caps.append(int(soft))
    try:
        top = Path("/sys/fs/cgroup/memory.max").read_text().strip()
        used = Path("/sys/fs/cgroup/memory.current").read_text().strip()
        if top != "max":
            caps.append(int(top) - int(used))
    except (OSError, ValueError):
        pass
    return min(caps) if caps else None


def check_memory(samples: int, model: CostModel, what: str,
                 allowed: int | None = None) -> float:
    """The predicted peak of ``samples``; refuse up front what cannot fit.

    Raises
    ------
    CommandError
        When the predicted peak is above ``allowed`` (default :func:`allowed_memory`); the
        message gives both sizes and what to do.
    """
    allowed = allowed_memory() if allowed is None else allowed
    if allowed is not None:
        refusal = memory_refusal(samples, model, what, allowed)
        if refusal:
            raise CommandError(refusal)
    return model.peak_bytes(samples)


class EtaProgress(Progress):
    """:class:`~app.services.runs.progress.Progress` whose step lines (``" 26 % ..."``) end with the
    time left of a run expected to take ``expected_s`` (``(about 40 s left)``), or say that it
    is taking longer.

    The estimate is the measured CPU-time model (:class:`CostModel`): the diagnosis's own
    progress fraction is not proportional to its time (its rounds differ in size).
    """

    _step = re.compile(r"^\s*\d+ % ")  # the diagnosis's steps ("  26 % round 2: ...")

    def __init__(self, command: str, expected_s: float, quiet: bool = False,
                 sink: Callable[[str], object] | None = None) -> None:
        super().__init__(command, quiet=quiet, sink=sink)
        self.expected_s = float(expected_s)

    def __call__(self, message: str) -> None:
        if not self._step.match(message) or message.lstrip().startswith("100 %"):
            super().__call__(message)
            return
        # the caller chose to show the time left: whatever the run is expected to take
        left = time_left_text(self.expected_s, time.perf_counter() - self.t0, from_s=0.0)
        super().__call__(f"{message} ({left})")

